// libFuzzer target for the mesh import path (assimp, then our weld, checks and
// orientation): the first byte picks the file's extension, the rest is its
// content. Any input loads as a closed, outward-wound mesh or is refused with a
// message naming the file; never a crash or a sanitizer report.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "scene/mesh_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* kExt[] = {"obj", "stl", "ply", "gltf", "off"};
  const std::string path = "/tmp/graspsim_mesh_fuzz_" + std::to_string(getpid()) + "." + kExt[data[0] % 5];
  {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  gs::TriangleMesh mesh;
  std::string error;
  // a bound on triangles keeps each input's work small
  const bool ok = gs::app::ImportMesh(path, 1.0, &mesh, &error, 20000, 3.0);
  std::remove(path.c_str());
  if (!ok && error.find(path) == std::string::npos) {
    std::fprintf(stderr, "mesh_fuzz: refused without naming the file: %s\n", error.c_str());
    std::abort();
  }
  if (ok) {
    if (mesh.triangles.empty()) std::abort();
    for (const auto& v : mesh.vertices)
      if (!v.allFinite()) std::abort();
  }
  return 0;
}
