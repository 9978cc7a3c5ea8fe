// Surface sampling: procedural shapes and triangle meshes turned into evenly
// spread point sets with outward unit normals (blue noise by weighted sample
// elimination, deterministic for a given seed).
#pragma once

#include <string>

#include "core/types.h"

namespace gs {

enum class EShape { Box, Sphere, Ellipsoid, Capsule, Cylinder, Mesh };

/// A procedural shape centred on its body frame's origin.
struct ShapeDesc {
  EShape type = EShape::Sphere;
  Vec3 half_extents = Vec3::Constant(0.01);  ///< box (m)
  double radius = 0.01;                      ///< sphere, capsule, cylinder (m)
  Vec3 semi_axes = Vec3::Constant(0.01);     ///< ellipsoid (m)
  double half_length = 0.01;                 ///< capsule, cylinder: half the axis length along z (m)
};

/// A closed triangle mesh (vertex positions in metres, counter-clockwise outward).
struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<Eigen::Vector3i> triangles;
};

enum class EMeshError { None, Empty, NotFinite, IndexOutOfRange, Degenerate, Open, NonManifold };
const char* ToString(EMeshError e);

/// Checks a mesh is non-empty, finite, closed and edge-manifold. When it is and
/// its signed volume is negative, flips every triangle so that normals point outward.
EMeshError ValidateAndOrientMesh(TriangleMesh* mesh);

/// Surface area of a procedural shape (m^2).
double SurfaceArea(const ShapeDesc& shape);

/// Signed distance from p to the analytic surface (negative inside) and the outward
/// unit normal of the closest surface point. For tests and accuracy benchmarks.
double AnalyticDistance(const ShapeDesc& shape, const Vec3& p, Vec3* normal = nullptr);

/// Samples exactly `count` points on the shape's surface, evenly spread.
/// Returns false (and leaves `out` empty) when count < 4 or the shape's sizes are not positive.
bool SampleShape(const ShapeDesc& shape, int count, uint64_t seed, PointCloud* out);

/// Samples exactly `count` points on a validated mesh, evenly spread, normals from the faces.
bool SampleMesh(const TriangleMesh& mesh, int count, uint64_t seed, PointCloud* out);

/// Mean distance from each point to its nearest neighbour (m).
double MeanSpacing(const PointCloud& cloud);

}  // namespace gs
