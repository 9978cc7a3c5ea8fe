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

enum class EMeshError { None, Empty, NotFinite, IndexOutOfRange, Degenerate, Open, NonManifold, Inconsistent };
const char* ToString(EMeshError e);

/// What ValidateAndOrientMesh found, for error messages.
struct MeshCheckReport {
  EMeshError error = EMeshError::None;
  int64_t count = 0;     ///< how many vertices, indices, triangles or edges are at fault
  int64_t first = -1;    ///< index of the first offending vertex (NotFinite) or triangle (others), or -1
  bool flipped = false;  ///< every triangle was flipped to face outward
  double volume = 0;     ///< signed volume after orientation (m^3)
};

/// Checks a mesh is non-empty, finite, closed and edge-manifold. When it is and
/// its signed volume is negative, flips every triangle so that normals point outward.
/// Checks in order: Empty, NotFinite, IndexOutOfRange, Degenerate (a triangle with
/// twice its area below 1e-14 of the squared bounding-box diagonal, or a closed mesh
/// of no volume), NonManifold (an edge in more than two triangles), Open (an edge in
/// one triangle), Inconsistent (two neighbouring triangles wound the same way).
/// The mesh is left unchanged unless the result is None. Vertices are not welded.
EMeshError ValidateAndOrientMesh(TriangleMesh* mesh);
/// The same, filling `report` (may be null) with counts for error messages.
EMeshError ValidateAndOrientMesh(TriangleMesh* mesh, MeshCheckReport* report);

/// Signed volume enclosed by a closed mesh (m^3), positive when wound outward.
double SignedVolume(const TriangleMesh& mesh);
/// Total triangle area (m^2).
double SurfaceArea(const TriangleMesh& mesh);

/// Surface area of a procedural shape (m^2); 0 for EShape::Mesh or invalid sizes.
/// The ellipsoid's is exact (Carlson's symmetric elliptic integral R_G).
double SurfaceArea(const ShapeDesc& shape);

/// Signed distance from p to the analytic surface (negative inside) and the outward
/// unit normal of the closest surface point. For tests and accuracy benchmarks.
/// NaN (normal zero) for EShape::Mesh or sizes that are not positive and finite.
double AnalyticDistance(const ShapeDesc& shape, const Vec3& p, Vec3* normal = nullptr);

/// Most points SampleShape and SampleMesh accept.
constexpr int kMaxSampleCount = 5000000;

/// Samples exactly `count` points on the shape's surface, evenly spread.
/// Returns false (and leaves `out` empty) when count < 4 or the shape's sizes are not positive.
/// Also false for count > kMaxSampleCount and for EShape::Mesh (use SampleMesh).
/// Capsule half_length may be 0 (a sphere). Points come in grid-cell order (nearby points
/// are mostly close in the arrays).
bool SampleShape(const ShapeDesc& shape, int count, uint64_t seed, PointCloud* out);

/// Samples exactly `count` points on a validated mesh, evenly spread, normals from the faces.
/// Returns false (and leaves `out` empty) for count < 4 or > kMaxSampleCount, an empty or
/// non-finite mesh, indices out of range or no area. Zero-area triangles get no points.
bool SampleMesh(const TriangleMesh& mesh, int count, uint64_t seed, PointCloud* out);

/// Plain area-uniform random points (the candidates SampleShape starts from, no
/// elimination): for tests and benchmarks. False for count < 1 or > 6 * kMaxSampleCount
/// or invalid shapes.
bool SampleShapeRandom(const ShapeDesc& shape, int count, uint64_t seed, PointCloud* out);
/// The same on a mesh (normals from the faces); false for the meshes SampleMesh refuses.
bool SampleMeshRandom(const TriangleMesh& mesh, int count, uint64_t seed, PointCloud* out);

/// Mean distance from each point to its nearest neighbour (m); 0 for fewer than 2 points.
double MeanSpacing(const PointCloud& cloud);

}  // namespace gs
