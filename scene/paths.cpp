#include "scene/paths.h"

#include <filesystem>
#include <vector>

namespace gs::app {

std::string ResolveResource(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (path.empty() || fs::exists(path, ec)) return path;
  if (!fs::path(path).is_relative()) return path;
  // an installed binary: PREFIX/bin/graspsim beside PREFIX/share/graspsim
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  std::vector<fs::path> roots = {fs::path(GRASPSIM_SOURCE_DIR)};
  if (!ec) roots.push_back(exe.parent_path().parent_path() / "share" / "graspsim");
  for (const fs::path& root : roots) {
    const fs::path candidate = root / path;
    if (fs::exists(candidate, ec)) return candidate.string();
  }
  return path;
}

}  // namespace gs::app
