// libFuzzer target for scene files: any text is either a valid scene or refused
// with errors that name the file and a line and column inside the text; never a
// crash, an exception escaping, or a sanitizer report. (Building the scene's
// geometry is not fuzzed here: it samples thousands of points per body.)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "scene/scene_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  gs::app::Scene scene;
  std::vector<gs::app::SceneError> errors;
  const bool ok = gs::app::LoadSceneFromString(text, "fuzz.yaml", &scene, &errors);
  if (!ok && errors.empty()) {
    std::fprintf(stderr, "scene_fuzz: refused without an error\n");
    std::abort();
  }
  const int lines = 1 + static_cast<int>(std::count(text.begin(), text.end(), '\n'));
  for (const auto& e : errors) {
    if (e.file.empty() || e.message.empty() || e.line < 0 || e.line > lines + 1 || e.column < 0) {
      std::fprintf(stderr, "scene_fuzz: bad error %s:%d:%d: %s\n", e.file.c_str(), e.line, e.column, e.message.c_str());
      std::abort();
    }
  }
  return 0;
}
