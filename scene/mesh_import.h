// Mesh files (OBJ, STL, PLY, glTF and whatever else assimp reads) turned into one
// closed, outward-wound triangle mesh in metres, ready for gs::SampleMesh.
#pragma once

#include <cstddef>
#include <string>

#include "core/sampling.h"

namespace gs::app {

/// Most triangles ImportMesh accepts by default (after triangulation, all meshes).
constexpr size_t kMaxImportTriangles = 5000000;

/// Loads every mesh of the file's scene (node transforms applied, polygons
/// triangulated, point and line primitives ignored), multiplies positions by `scale`
/// (file units to metres), welds vertices closer than the larger of 1e-9 of the
/// bounding-box diagonal and two float32 ulps of the largest coordinate (assimp reads
/// single precision), then checks and orients the result (gs::ValidateAndOrientMesh).
/// On failure returns false, leaves `out` empty and sets `error` (may be null) to a
/// message naming the file and the problem, e.g.
/// "mesh 'x.stl': open surface: 3 boundary edges (a closed surface is required)".
///
/// assimp runs in a child process: a file on which it crashes or that it has not
/// read within `timeout_s` seconds is refused with a message saying so.
bool ImportMesh(const std::string& path, double scale, gs::TriangleMesh* out, std::string* error,
                size_t max_triangles = kMaxImportTriangles, double timeout_s = 60.0);

}  // namespace gs::app
