#include "core/mls.h"

#include <gtest/gtest.h>

#include <random>

#include "core/point_grid.h"
#include "core/sampling.h"

namespace gs {
namespace {

struct Sampled {
  ShapeDesc shape;
  PointCloud cloud;
  PointGrid grid;
  double spacing = 0;
};

std::unique_ptr<Sampled> Sample(const ShapeDesc& shape, int n) {
  auto s = std::make_unique<Sampled>();
  s->shape = shape;
  EXPECT_TRUE(SampleShape(shape, n, 9, &s->cloud));
  s->spacing = MeanSpacing(s->cloud);
  s->grid.Build(s->cloud.positions, 3 * s->spacing);
  return s;
}

// max projection error (in spacings) and max normal error (degrees) over points near the surface
void Accuracy(const Sampled& s, bool quadric, double* max_err, double* max_deg) {
  MlsParams p = RecommendedMlsParams(s.spacing);
  p.quadric = quadric;
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<int> nbrs;
  *max_err = *max_deg = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vec3 x = s.cloud.positions[(k * 131) % s.cloud.size()] + s.spacing * Vec3(u(rng), u(rng), u(rng));
    nbrs.clear();
    s.grid.Query(x, p.support * p.bandwidth + 2 * s.spacing, &nbrs);
    MlsProjection proj;
    ASSERT_TRUE(MlsProject(s.cloud.positions.data(), s.cloud.normals.data(), nbrs.data(),
                           static_cast<int>(nbrs.size()), x, p, &proj));
    Vec3 n;
    *max_err = std::max(*max_err, std::abs(AnalyticDistance(s.shape, proj.point, &n)) / s.spacing);
    *max_deg = std::max(*max_deg, std::acos(std::clamp(n.dot(proj.normal), -1.0, 1.0)) * 180 / M_PI);
  }
}

TEST(Mls, QuadricProjectionMeetsOnePercentOfTheSpacingOnCurvedSurfaces) {
  ShapeDesc sphere;
  sphere.type = EShape::Sphere;
  sphere.radius = 0.008;
  ShapeDesc ellipsoid;
  ellipsoid.type = EShape::Ellipsoid;
  ellipsoid.semi_axes = Vec3(0.008, 0.008, 0.011);
  for (const ShapeDesc& shape : {sphere, ellipsoid}) {
    auto s = Sample(shape, 2400);
    double err, deg;
    Accuracy(*s, true, &err, &deg);
    EXPECT_LT(err, 0.01);  // measured: 0.05% (sphere), 0.15% (ellipsoid)
    EXPECT_LT(deg, 1.0);   // measured: 0.01 and 0.22 degrees
    // the plane-only MLS shrinks curved surfaces by about h^2 / 2R: many times worse
    double plane_err, plane_deg;
    Accuracy(*s, false, &plane_err, &plane_deg);
    EXPECT_GT(plane_err, 10 * err);
  }
}

TEST(Mls, PlaneIsReproducedExactlyAndSignsFollowTheNormals) {
  PointCloud c;
  for (int i = -10; i <= 10; ++i)
    for (int j = -10; j <= 10; ++j) {
      c.positions.push_back(Vec3(i * 1e-3, j * 1e-3, 0.002));
      c.normals.push_back(Vec3::UnitZ());
    }
  std::vector<int> idx(c.size());
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
  const MlsParams p = RecommendedMlsParams(1e-3);
  MlsProjection proj;
  ASSERT_TRUE(MlsProject(c.positions.data(), c.normals.data(), idx.data(), static_cast<int>(idx.size()),
                         Vec3(0.0013, -0.0021, 0.0025), p, &proj));
  EXPECT_NEAR(proj.point.z(), 0.002, 1e-12);
  EXPECT_NEAR(proj.point.x(), 0.0013, 1e-12);
  EXPECT_NEAR((proj.normal - Vec3::UnitZ()).norm(), 0, 1e-9);
  // f = n.(a - p): negative above (outside), positive below
  EXPECT_LT(MlsImplicit(c.positions.data(), c.normals.data(), idx.data(), static_cast<int>(idx.size()),
                        Vec3(0, 0, 0.0025), p),
            0);
  EXPECT_GT(MlsImplicit(c.positions.data(), c.normals.data(), idx.data(), static_cast<int>(idx.size()),
                        Vec3(0, 0, 0.0015), p),
            0);
  // flipped stored normals flip the orientation
  for (Vec3& n : c.normals) n = -n;
  ASSERT_TRUE(MlsProject(c.positions.data(), c.normals.data(), idx.data(), static_cast<int>(idx.size()),
                         Vec3(0, 0, 0.0025), p, &proj));
  EXPECT_NEAR((proj.normal + Vec3::UnitZ()).norm(), 0, 1e-9);
}

TEST(Mls, DegenerateInputsFailCleanlyOrStayFinite) {
  const MlsParams p = RecommendedMlsParams(1e-3);
  MlsProjection proj;
  MlsFit fit;
  std::vector<Vec3> pts = {Vec3(0, 0, 0), Vec3(1e-3, 0, 0)};
  std::vector<Vec3> nrm(2, Vec3::UnitZ());
  int idx[] = {0, 1};
  EXPECT_FALSE(MlsPlaneFit(pts.data(), nrm.data(), idx, 2, Vec3::Zero(), p, &fit));
  EXPECT_FALSE(MlsProject(pts.data(), nrm.data(), idx, 2, Vec3::Zero(), p, &proj));
  EXPECT_TRUE(std::isnan(MlsImplicit(pts.data(), nrm.data(), idx, 2, Vec3::Zero(), p)));
  // duplicates and collinear points: no NaN comes out
  std::vector<Vec3> dup(30, Vec3(0, 0, 0)), line;
  for (int i = 0; i < 30; ++i) line.push_back(Vec3(i * 1e-4, 0, 0));
  std::vector<Vec3> n30(30, Vec3::UnitZ());
  std::vector<int> all(30);
  for (int i = 0; i < 30; ++i) all[i] = i;
  for (const auto* set : {&dup, &line}) {
    if (MlsProject(set->data(), n30.data(), all.data(), 30, Vec3(1e-4, 1e-4, 1e-4), p, &proj)) {
      EXPECT_TRUE(proj.point.allFinite());
      EXPECT_TRUE(proj.normal.allFinite());
    }
  }
  // nothing within reach
  EXPECT_FALSE(MlsProject(line.data(), n30.data(), all.data(), 30, Vec3(1, 1, 1), p, &proj));
}

}  // namespace
}  // namespace gs
