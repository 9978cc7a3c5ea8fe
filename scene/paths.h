// Locating files that ship with the repository (config/, assets/) whatever the
// working directory: as given, then beside the source tree the binary was built from.
#pragma once

#include <string>

namespace gs::app {

/// Returns `path` itself when it exists; otherwise the first existing of
/// GRASPSIM_SOURCE_DIR/path; otherwise `path` unchanged (the caller reports it missing).
std::string ResolveResource(const std::string& path);

}  // namespace gs::app
