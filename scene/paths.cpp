#include "scene/paths.h"

#include <filesystem>

namespace gs::app {

std::string ResolveResource(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (path.empty() || fs::exists(path, ec)) return path;
  if (fs::path(path).is_relative()) {
    const fs::path candidate = fs::path(GRASPSIM_SOURCE_DIR) / path;
    if (fs::exists(candidate, ec)) return candidate.string();
  }
  return path;
}

}  // namespace gs::app
