// A body's geometry, built once in its rest frame: the sampled surface, its
// MLS parameters and its sphere tree. One builder shared by the app, the
// tests and the benchmarks.
#pragma once

#include "core/mls.h"
#include "core/sampling.h"
#include "core/sphere_tree.h"
#include "core/types.h"

namespace gs {

struct BodyGeometry {
  ShapeDesc shape;
  bool is_plane = false;
  PointCloud cloud;
  SphereTree tree;
  MlsParams mls;
  double spacing = 0.0;  ///< mean point spacing (m)
  double area = 0.0;     ///< surface area (m^2)
};

struct GeometryOptions {
  int points = 0;
  int control_points = 0;
  uint64_t seed = 1;
  double bandwidth = 0.0;  ///< MLS bandwidth h (m); 0 = recommended multiple of the spacing
  double border = 0.0;     ///< r_eps (m); 0 = the kernel's support, so any projection inside a leaf sees all its weighted points
};

enum class EGeometryError { None, BadShape, BadCounts, TreeFailed };
const char* ToString(EGeometryError e);

/// Samples a procedural shape and builds its tree.
EGeometryError BuildShapeGeometry(const ShapeDesc& shape, const GeometryOptions& opt, BodyGeometry* out);
/// Samples a validated mesh and builds its tree.
EGeometryError BuildMeshGeometry(const TriangleMesh& mesh, const GeometryOptions& opt, BodyGeometry* out);
/// Builds the tree over an existing point cloud (area: its surface area, m^2).
EGeometryError BuildCloudGeometry(PointCloud cloud, double area, const GeometryOptions& opt, BodyGeometry* out);
/// An analytic plane (z = 0 of the body frame, normal +z).
void BuildPlaneGeometry(BodyGeometry* out);

}  // namespace gs
