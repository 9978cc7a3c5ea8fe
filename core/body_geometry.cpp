#include "core/body_geometry.h"

#include <cmath>

namespace gs {

const char* ToString(EGeometryError e) {
  switch (e) {
    case EGeometryError::None: return "ok";
    case EGeometryError::BadShape: return "the shape's sizes must be positive and finite";
    case EGeometryError::BadCounts: return "points must be at least 4 and control_points between 1 and points";
    case EGeometryError::TreeFailed: return "the sphere tree could not be built (non-finite or too few points)";
  }
  return "unknown";
}

EGeometryError BuildCloudGeometry(PointCloud cloud, double area, const GeometryOptions& opt, BodyGeometry* out) {
  const int n = static_cast<int>(cloud.size());
  if (n < 4 || opt.control_points < 1 || opt.control_points > n) return EGeometryError::BadCounts;
  out->is_plane = false;
  out->cloud = std::move(cloud);
  out->area = area;
  out->spacing = MeanSpacing(out->cloud);
  out->mls = RecommendedMlsParams(out->spacing);
  if (opt.bandwidth > 0) out->mls.bandwidth = opt.bandwidth;
  SphereTreeParams tp;
  tp.leaf_count = opt.control_points;
  tp.border = opt.border > 0 ? opt.border : out->mls.support * out->mls.bandwidth;
  if (out->tree.Build(out->cloud, out->mls, tp) != SphereTree::EBuildError::None) return EGeometryError::TreeFailed;
  return EGeometryError::None;
}

EGeometryError BuildShapeGeometry(const ShapeDesc& shape, const GeometryOptions& opt, BodyGeometry* out) {
  if (opt.points < 4 || opt.control_points < 1 || opt.control_points > opt.points) return EGeometryError::BadCounts;
  PointCloud cloud;
  if (!SampleShape(shape, opt.points, opt.seed, &cloud)) return EGeometryError::BadShape;
  out->shape = shape;
  return BuildCloudGeometry(std::move(cloud), SurfaceArea(shape), opt, out);
}

EGeometryError BuildMeshGeometry(const TriangleMesh& mesh, const GeometryOptions& opt, BodyGeometry* out) {
  if (opt.points < 4 || opt.control_points < 1 || opt.control_points > opt.points) return EGeometryError::BadCounts;
  PointCloud cloud;
  if (!SampleMesh(mesh, opt.points, opt.seed, &cloud)) return EGeometryError::BadShape;
  double area = 0.0;
  for (const auto& t : mesh.triangles)
    area += 0.5 * (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]).norm();
  out->shape = ShapeDesc{};
  out->shape.type = EShape::Mesh;
  return BuildCloudGeometry(std::move(cloud), area, opt, out);
}

void BuildPlaneGeometry(BodyGeometry* out) {
  *out = BodyGeometry{};
  out->is_plane = true;
}

}  // namespace gs
