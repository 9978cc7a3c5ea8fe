// Locating files that ship with the repository (config/, assets/) whatever the
// working directory: as given, then in the source tree the binary was built from,
// then in PREFIX/share/graspsim beside an installed PREFIX/bin/graspsim.
#pragma once

#include <string>

namespace gs::app {

/// Returns `path` itself when it exists; otherwise the first existing of
/// GRASPSIM_SOURCE_DIR/path and PREFIX/share/graspsim/path (PREFIX: the folder
/// above the binary's); otherwise `path` unchanged (the caller reports it missing).
std::string ResolveResource(const std::string& path);

}  // namespace gs::app
