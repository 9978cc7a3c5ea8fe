#include "core/sampling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "core/point_grid.h"

namespace gs {
namespace {

constexpr double kPi = 3.14159265358979323846;

ShapeDesc Box(double hx, double hy, double hz) {
  ShapeDesc s;
  s.type = EShape::Box;
  s.half_extents = Vec3(hx, hy, hz);
  return s;
}
ShapeDesc Sphere(double r) {
  ShapeDesc s;
  s.type = EShape::Sphere;
  s.radius = r;
  return s;
}
ShapeDesc Ellipsoid(double a, double b, double c) {
  ShapeDesc s;
  s.type = EShape::Ellipsoid;
  s.semi_axes = Vec3(a, b, c);
  return s;
}
ShapeDesc Capsule(double r, double l) {
  ShapeDesc s;
  s.type = EShape::Capsule;
  s.radius = r;
  s.half_length = l;
  return s;
}
ShapeDesc Cylinder(double r, double l) {
  ShapeDesc s;
  s.type = EShape::Cylinder;
  s.radius = r;
  s.half_length = l;
  return s;
}

// mm-sized shapes of every kind
std::vector<ShapeDesc> AllShapes() {
  return {Box(0.01, 0.006, 0.004), Sphere(0.01), Ellipsoid(0.008, 0.008, 0.011), Ellipsoid(0.012, 0.007, 0.004),
          Capsule(0.006, 0.01), Cylinder(0.008, 0.012)};
}

const char* Name(const ShapeDesc& s) {
  switch (s.type) {
    case EShape::Box: return "box";
    case EShape::Sphere: return "sphere";
    case EShape::Ellipsoid: return "ellipsoid";
    case EShape::Capsule: return "capsule";
    case EShape::Cylinder: return "cylinder";
    case EShape::Mesh: return "mesh";
  }
  return "?";
}

// nearest-neighbour distance of every point (brute-force-free, via the grid)
std::vector<double> NearestDistances(const std::vector<Vec3>& pts, double guess) {
  PointGrid grid;
  grid.Build(pts, guess);
  std::vector<double> out(pts.size());
  std::vector<int> buf;
  for (size_t i = 0; i < pts.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (double r = guess; best == std::numeric_limits<double>::infinity(); r *= 2) {
      buf.clear();
      grid.Query(pts[i], r, &buf);
      for (int j : buf)
        if (j != static_cast<int>(i)) best = std::min(best, (pts[j] - pts[i]).norm());
    }
    out[i] = best;
  }
  return out;
}

struct Spread {
  double min_nn = 0, mean_nn = 0;
  double Ratio() const { return min_nn / mean_nn; }
};

Spread Measure(const std::vector<Vec3>& pts, double guess) {
  const std::vector<double> d = NearestDistances(pts, guess);
  Spread s;
  s.min_nn = *std::min_element(d.begin(), d.end());
  double sum = 0;
  for (double x : d) sum += x;
  s.mean_nn = sum / d.size();
  return s;
}

// plain uniform random points on the surface (a different generator from the
// library's): random points in a shell around the surface, projected onto it, then
// thinned so that the density is roughly area-uniform is not needed for coverage
std::vector<Vec3> DenseSurfacePoints(const ShapeDesc& s, int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vec3 ext;
  switch (s.type) {
    case EShape::Box: ext = s.half_extents; break;
    case EShape::Ellipsoid: ext = s.semi_axes; break;
    case EShape::Capsule: ext = Vec3(s.radius, s.radius, s.radius + s.half_length); break;
    case EShape::Cylinder: ext = Vec3(s.radius, s.radius, s.half_length); break;
    default: ext = Vec3::Constant(s.radius); break;
  }
  std::vector<Vec3> out;
  out.reserve(n);
  while (static_cast<int>(out.size()) < n) {
    const Vec3 p(1.3 * ext.x() * u(rng), 1.3 * ext.y() * u(rng), 1.3 * ext.z() * u(rng));
    Vec3 nrm;
    const double d = AnalyticDistance(s, p, &nrm);
    out.push_back(p - d * nrm);
  }
  return out;
}

// max over dense surface points of the distance to the nearest sample
double CoverageGap(const ShapeDesc& s, const PointCloud& cloud, double spacing, int dense) {
  PointGrid grid;
  grid.Build(cloud.positions, 2 * spacing);
  double worst = 0;
  for (const Vec3& q : DenseSurfacePoints(s, dense, 99)) {
    int i = grid.Nearest(q, 2 * spacing);
    if (i < 0) i = grid.Nearest(q, 20 * spacing);
    if (i < 0) return std::numeric_limits<double>::infinity();
    worst = std::max(worst, (cloud.positions[i] - q).norm());
  }
  return worst;
}

// is n the outward normal of a face of a box or cylinder that contains p?
bool IsFaceNormalAt(const ShapeDesc& s, const Vec3& p, const Vec3& n) {
  const double tol = 1e-12;
  if (s.type == EShape::Box) {
    for (int k = 0; k < 3; ++k)
      for (double sign : {-1.0, 1.0}) {
        Vec3 face = Vec3::Zero();
        face[k] = sign;
        if (n == face && std::abs(p[k] - sign * s.half_extents[k]) < tol) return true;
      }
    return false;
  }
  const double rho = std::hypot(p.x(), p.y());
  if (n.z() == 0 && std::abs(rho - s.radius) < tol) return (n - Vec3(p.x() / rho, p.y() / rho, 0)).norm() < 1e-12;
  for (double sign : {-1.0, 1.0})
    if (n == Vec3(0, 0, sign) && std::abs(p.z() - sign * s.half_length) < tol) return true;
  return false;
}

// share of an ellipsoid's area with |z| > z_cut, by fine parametric integration
double EllipsoidAreaShareAbove(const Vec3& e, double z_cut) {
  double total = 0, part = 0;
  const int nt = 2000, np = 400;
  for (int i = 0; i < nt; ++i) {
    const double th = kPi * (i + 0.5) / nt;
    for (int j = 0; j < np; ++j) {
      const double ph = 2 * kPi * (j + 0.5) / np;
      const Vec3 dth(e.x() * std::cos(th) * std::cos(ph), e.y() * std::cos(th) * std::sin(ph), -e.z() * std::sin(th));
      const Vec3 dph(-e.x() * std::sin(th) * std::sin(ph), e.y() * std::sin(th) * std::cos(ph), 0);
      const double da = dth.cross(dph).norm();
      total += da;
      if (std::abs(e.z() * std::cos(th)) > z_cut) part += da;
    }
  }
  return part / total;
}

TEST(SampleShapeRandom, AreaUniformOnEveryPart) {
  const int n = 300000;
  // 5 binomial standard deviations at p = 0.5
  const double tol = 5 * std::sqrt(0.25 / n);
  auto share = [&](const PointCloud& c, auto pred) {
    int k = 0;
    for (size_t i = 0; i < c.size(); ++i) k += pred(c.positions[i], c.normals[i]);
    return static_cast<double>(k) / c.size();
  };
  PointCloud c;
  // box: the +-x faces
  const ShapeDesc box = Box(0.01, 0.006, 0.004);
  ASSERT_TRUE(SampleShapeRandom(box, n, 1, &c));
  EXPECT_NEAR(share(c, [](const Vec3&, const Vec3& nr) { return std::abs(nr.x()) == 1; }),
              2 * 4 * 0.006 * 0.004 / SurfaceArea(box), tol);
  EXPECT_NEAR(share(c, [](const Vec3& p, const Vec3& nr) { return nr.z() == 1 && p.x() > 0.005; }),
              4 * 0.01 * 0.006 / SurfaceArea(box) / 4, tol);
  // sphere: the cap z > r/2 has a quarter of the area (Archimedes)
  ASSERT_TRUE(SampleShapeRandom(Sphere(0.01), n, 1, &c));
  EXPECT_NEAR(share(c, [](const Vec3& p, const Vec3&) { return p.z() > 0.005; }), 0.25, tol);
  EXPECT_NEAR(share(c, [](const Vec3& p, const Vec3&) { return p.x() > 0 && p.y() > 0; }), 0.25, tol);
  // capsule: the caps, and a band of the side
  const ShapeDesc cap = Capsule(0.006, 0.01);
  ASSERT_TRUE(SampleShapeRandom(cap, n, 1, &c));
  EXPECT_NEAR(share(c, [](const Vec3& p, const Vec3&) { return std::abs(p.z()) > 0.01; }),
              4 * kPi * 0.006 * 0.006 / SurfaceArea(cap), tol);
  EXPECT_NEAR(share(c, [](const Vec3& p, const Vec3&) { return std::abs(p.z()) > 0.013; }),
              2 * 2 * kPi * 0.006 * 0.003 / SurfaceArea(cap), tol);  // zone area 2 pi r h
  // cylinder: the caps, and the inner disk of half the radius on them
  const ShapeDesc cyl = Cylinder(0.008, 0.012);
  ASSERT_TRUE(SampleShapeRandom(cyl, n, 1, &c));
  EXPECT_NEAR(share(c, [](const Vec3&, const Vec3& nr) { return std::abs(nr.z()) == 1; }),
              2 * kPi * 0.008 * 0.008 / SurfaceArea(cyl), tol);
  EXPECT_NEAR(share(c, [](const Vec3& p, const Vec3& nr) { return std::abs(nr.z()) == 1 && p.head<2>().norm() < 0.004; }),
              0.5 * kPi * 0.008 * 0.008 / SurfaceArea(cyl), tol);
  // elongated ellipsoid: the ends, against numeric integration
  const ShapeDesc ell = Ellipsoid(0.004, 0.005, 0.015);
  ASSERT_TRUE(SampleShapeRandom(ell, n, 1, &c));
  EXPECT_NEAR(share(c, [](const Vec3& p, const Vec3&) { return std::abs(p.z()) > 0.0075; }),
              EllipsoidAreaShareAbove(ell.semi_axes, 0.0075), tol);
  EXPECT_NEAR(share(c, [](const Vec3& p, const Vec3&) { return std::abs(p.z()) > 0.013; }),
              EllipsoidAreaShareAbove(ell.semi_axes, 0.013), tol);
  for (size_t i = 0; i < c.size(); ++i) ASSERT_LT(std::abs(AnalyticDistance(ell, c.positions[i])), 1e-17);
  // deterministic, and refuses what SampleShape refuses
  PointCloud again;
  ASSERT_TRUE(SampleShapeRandom(ell, 1000, 1, &again));
  EXPECT_TRUE(std::equal(again.positions.begin(), again.positions.end(), c.positions.begin()));
  EXPECT_FALSE(SampleShapeRandom(Sphere(-1), 10, 1, &c));
  EXPECT_EQ(c.size(), 0u);
  EXPECT_FALSE(SampleShapeRandom(Sphere(1), 0, 1, &c));
}

TEST(SampleShape, ExactCountsForEveryShape) {
  for (const ShapeDesc& s : AllShapes())
    for (int count : {4, 5, 17, 100, 1001}) {
      PointCloud c;
      ASSERT_TRUE(SampleShape(s, count, 1, &c)) << Name(s) << " " << count;
      EXPECT_EQ(static_cast<int>(c.positions.size()), count) << Name(s);
      EXPECT_EQ(static_cast<int>(c.normals.size()), count) << Name(s);
    }
}

TEST(SampleShape, RejectsBadInputAndLeavesOutputEmpty) {
  PointCloud c;
  auto junk = [&] {
    c.positions.assign(3, Vec3::Ones());
    c.normals.assign(3, Vec3::Ones());
  };
  junk();
  EXPECT_FALSE(SampleShape(Sphere(0.01), 3, 1, &c));
  EXPECT_EQ(c.size(), 0u);
  EXPECT_TRUE(c.normals.empty());
  junk();
  EXPECT_FALSE(SampleShape(Sphere(-0.01), 100, 1, &c));
  EXPECT_EQ(c.size(), 0u);
  junk();
  EXPECT_FALSE(SampleShape(Sphere(std::nan("")), 100, 1, &c));
  EXPECT_EQ(c.size(), 0u);
  junk();
  EXPECT_FALSE(SampleShape(Box(0.01, 0.0, 0.01), 100, 1, &c));
  EXPECT_EQ(c.size(), 0u);
  EXPECT_FALSE(SampleShape(Ellipsoid(0.01, 0.01, -1), 100, 1, &c));
  EXPECT_FALSE(SampleShape(Cylinder(0.01, 0.0), 100, 1, &c));
  EXPECT_FALSE(SampleShape(Capsule(0.0, 0.01), 100, 1, &c));
  EXPECT_FALSE(SampleShape(Sphere(0.01), kMaxSampleCount + 1, 1, &c));
  ShapeDesc mesh;
  mesh.type = EShape::Mesh;
  EXPECT_FALSE(SampleShape(mesh, 100, 1, &c));
  EXPECT_FALSE(SampleShape(Sphere(0.01), 100, 1, nullptr));
  // a capsule of zero length is a sphere and is fine
  EXPECT_TRUE(SampleShape(Capsule(0.01, 0.0), 100, 1, &c));
  EXPECT_EQ(c.size(), 100u);
}

TEST(SampleShape, DeterministicPerSeed) {
  for (const ShapeDesc& s : AllShapes()) {
    PointCloud a, b, c;
    ASSERT_TRUE(SampleShape(s, 500, 42, &a));
    ASSERT_TRUE(SampleShape(s, 500, 42, &b));
    ASSERT_TRUE(SampleShape(s, 500, 43, &c));
    bool identical = true;
    for (size_t i = 0; i < a.size(); ++i)
      identical = identical && a.positions[i] == b.positions[i] && a.normals[i] == b.normals[i];
    EXPECT_TRUE(identical) << Name(s);
    int same = 0;
    for (size_t i = 0; i < a.size(); ++i) same += a.positions[i] == c.positions[i];
    EXPECT_LT(same, 5) << Name(s);
  }
}

TEST(SampleShape, PointsOnSurfaceWithAnalyticNormals) {
  for (const ShapeDesc& s : AllShapes()) {
    PointCloud c;
    ASSERT_TRUE(SampleShape(s, 3000, 7, &c));
    double worst_d = 0, worst_unit = 0, worst_dot = 1;
    int bad_face = 0;
    for (size_t i = 0; i < c.size(); ++i) {
      Vec3 an;
      const double d = AnalyticDistance(s, c.positions[i], &an);
      worst_d = std::max(worst_d, std::abs(d));
      worst_unit = std::max(worst_unit, std::abs(c.normals[i].norm() - 1));
      if (s.type == EShape::Box || s.type == EShape::Cylinder) {
        bad_face += !IsFaceNormalAt(s, c.positions[i], c.normals[i]);
      } else {
        worst_dot = std::min(worst_dot, c.normals[i].dot(an));
      }
    }
    EXPECT_LT(worst_d, 1e-15) << Name(s);  // mm shapes: far below the required 1e-9 m
    EXPECT_LT(worst_unit, 1e-14) << Name(s);
    EXPECT_GT(worst_dot, 1 - 1e-12) << Name(s);
    EXPECT_EQ(bad_face, 0) << Name(s);
  }
}

TEST(SampleShape, PointsSpreadOverPartsInProportionToArea) {
  // box faces: +-x, +-y, +-z get points in proportion to their areas
  const ShapeDesc box = Box(0.01, 0.006, 0.004);
  PointCloud c;
  ASSERT_TRUE(SampleShape(box, 6000, 3, &c));
  int per_face[6] = {0, 0, 0, 0, 0, 0};
  for (const Vec3& n : c.normals)
    for (int k = 0; k < 3; ++k)
      if (std::abs(n[k]) == 1) ++per_face[2 * k + (n[k] > 0)];
  const Vec3 h = box.half_extents;
  const double face_area[3] = {4 * h.y() * h.z(), 4 * h.z() * h.x(), 4 * h.x() * h.y()};
  for (int f = 0; f < 6; ++f) {
    const double want = 6000 * face_area[f / 2] / SurfaceArea(box);
    EXPECT_NEAR(per_face[f], want, 0.05 * want) << "face " << f;
  }
  // cylinder: side against caps
  const ShapeDesc cyl = Cylinder(0.008, 0.012);
  ASSERT_TRUE(SampleShape(cyl, 6000, 3, &c));
  int on_caps = 0;
  for (const Vec3& n : c.normals) on_caps += std::abs(n.z()) == 1;
  const double caps_want = 6000 * 2 * kPi * 0.008 * 0.008 / SurfaceArea(cyl);
  EXPECT_NEAR(on_caps, caps_want, 0.05 * caps_want);
  // elongated ellipsoid: the ends (|z| > c/2) get their area share (0.3 % of area per point)
  const ShapeDesc ell = Ellipsoid(0.004, 0.005, 0.015);
  ASSERT_TRUE(SampleShape(ell, 6000, 3, &c));
  int ends = 0;
  for (const Vec3& p : c.positions) ends += std::abs(p.z()) > 0.0075;
  const double ends_want = 6000 * EllipsoidAreaShareAbove(ell.semi_axes, 0.0075);
  EXPECT_NEAR(ends, ends_want, 0.05 * ends_want);
}

TEST(SampleShape, EvenSpreadAndCoverage) {
  for (const ShapeDesc& s : AllShapes()) {
    PointCloud c;
    ASSERT_TRUE(SampleShape(s, 2000, 11, &c));
    const double spacing = MeanSpacing(c);
    const Spread sp = Measure(c.positions, spacing);
    EXPECT_NEAR(sp.mean_nn, spacing, 1e-12 * spacing) << Name(s);
    std::printf("[ %-9s] 2000 pts: min/mean nn = %.3f, mean nn = %.3g m\n", Name(s), sp.Ratio(), sp.mean_nn);
    EXPECT_GT(sp.Ratio(), 0.75) << Name(s);  // measured 0.88-0.89
    const double gap = CoverageGap(s, c, spacing, 100000);
    std::printf("[ %-9s] coverage gap / mean spacing = %.3f\n", Name(s), gap / spacing);
    EXPECT_LT(gap, 1.5 * spacing) << Name(s);
  }
}

TEST(SampleShape, UniformRandomPointsFailTheEvennessBound) {
  // the evenness bound above must be one that plain random sampling does not meet
  for (const ShapeDesc& s : AllShapes()) {
    PointCloud c;
    ASSERT_TRUE(SampleShapeRandom(s, 2000, 5, &c));
    const Spread sp = Measure(c.positions, MeanSpacing(c));
    std::printf("[ %-9s] random: min/mean nn = %.3f\n", Name(s), sp.Ratio());
    EXPECT_LT(sp.Ratio(), 0.2) << Name(s);
  }
}

TEST(SampleShape, PaperBox36000Points) {
  const ShapeDesc box = Box(0.03, 0.03, 0.03);
  PointCloud c;
  // (no time limit asserted here: wall times flake on shared machines)
  ASSERT_TRUE(SampleShape(box, 36000, 1, &c));
  ASSERT_EQ(c.size(), 36000u);
  const double spacing = MeanSpacing(c);
  // hexagonal packing of 36,000 points on 0.0216 m^2 has a spacing of 0.83 mm
  const double hex = std::sqrt(2 * SurfaceArea(box) / (std::sqrt(3.0) * 36000));
  std::printf("box: mean spacing %.4g m (hexagonal %.4g m)\n", spacing, hex);
  // blue noise sits near 0.8 of it; uniform random points would give about 0.47
  EXPECT_GT(spacing, 0.7 * hex);
  EXPECT_LT(spacing, 1.0 * hex);
  PointCloud random;
  ASSERT_TRUE(SampleShapeRandom(box, 36000, 1, &random));
  const double random_spacing = MeanSpacing(random);
  std::printf("box: uniform random points: mean spacing %.4g m (%.2f of hexagonal)\n", random_spacing,
              random_spacing / hex);
  EXPECT_LT(random_spacing, 0.7 * hex);
  const Spread sp = Measure(c.positions, spacing);
  std::printf("box: min/mean nn = %.3f\n", sp.Ratio());
  EXPECT_GT(sp.Ratio(), 0.75);  // measured 0.885
  const double gap = CoverageGap(box, c, spacing, 300000);
  std::printf("box: coverage gap / mean spacing = %.3f\n", gap / spacing);
  EXPECT_LT(gap, 1.5 * spacing);
  for (size_t i = 0; i < c.size(); ++i) ASSERT_LT(std::abs(AnalyticDistance(box, c.positions[i])), 1e-15);
}

TEST(SampleShape, PaperFingertipEllipsoid2400Points) {
  const ShapeDesc ell = Ellipsoid(0.008, 0.008, 0.011);
  PointCloud c;
  ASSERT_TRUE(SampleShape(ell, 2400, 1, &c));
  ASSERT_EQ(c.size(), 2400u);
  const double spacing = MeanSpacing(c);
  const Spread sp = Measure(c.positions, spacing);
  std::printf("ellipsoid: min/mean nn = %.3f, spacing %.4g m\n", sp.Ratio(), spacing);
  EXPECT_GT(sp.Ratio(), 0.75);  // measured 0.889
  EXPECT_LT(CoverageGap(ell, c, spacing, 100000), 1.5 * spacing);
  for (size_t i = 0; i < c.size(); ++i) {
    Vec3 n;
    ASSERT_LT(std::abs(AnalyticDistance(ell, c.positions[i], &n)), 1e-15);
    ASSERT_GT(n.dot(c.normals[i]), 1 - 1e-12);
  }
}

TEST(SurfaceArea, ClosedForms) {
  EXPECT_DOUBLE_EQ(SurfaceArea(Box(0.03, 0.03, 0.03)), 6 * 0.06 * 0.06);
  EXPECT_DOUBLE_EQ(SurfaceArea(Box(1, 2, 3)), 8 * (2 + 6 + 3));
  EXPECT_DOUBLE_EQ(SurfaceArea(Sphere(2)), 16 * kPi);
  EXPECT_DOUBLE_EQ(SurfaceArea(Capsule(1, 2)), 4 * kPi + 2 * kPi * 4);
  EXPECT_DOUBLE_EQ(SurfaceArea(Cylinder(1, 2)), 2 * kPi + 2 * kPi * 4);
  EXPECT_NEAR(SurfaceArea(Ellipsoid(2, 2, 2)), 16 * kPi, 1e-13);
  // prolate spheroid a = b < c
  {
    const double a = 1, c = 3, e = std::sqrt(1 - a * a / (c * c));
    EXPECT_NEAR(SurfaceArea(Ellipsoid(a, c, a)), 2 * kPi * a * a * (1 + c / (a * e) * std::asin(e)), 1e-12);
  }
  // oblate spheroid a = b > c
  {
    const double a = 3, c = 1, e = std::sqrt(1 - c * c / (a * a));
    const double want = 2 * kPi * a * a * (1 + (1 - e * e) / e * std::atanh(e));
    EXPECT_NEAR(SurfaceArea(Ellipsoid(a, a, c)), want, 1e-12 * want);
  }
  ShapeDesc mesh;
  mesh.type = EShape::Mesh;
  EXPECT_EQ(SurfaceArea(mesh), 0.0);
  EXPECT_EQ(SurfaceArea(Sphere(-1)), 0.0);
}

TEST(SurfaceArea, TriaxialEllipsoidMatchesNumericIntegration) {
  for (const Vec3& e : {Vec3(0.008, 0.008, 0.011), Vec3(0.012, 0.007, 0.004), Vec3(1.0, 0.1, 0.5)}) {
    // Gauss-Legendre-free check: midpoint rule in theta (smooth, O(h^2)) and in phi (periodic)
    const int nt = 3000, np = 600;
    double area = 0;
    for (int i = 0; i < nt; ++i) {
      const double th = kPi * (i + 0.5) / nt;
      for (int j = 0; j < np; ++j) {
        const double ph = 2 * kPi * (j + 0.5) / np;
        const Vec3 dth(e.x() * std::cos(th) * std::cos(ph), e.y() * std::cos(th) * std::sin(ph), -e.z() * std::sin(th));
        const Vec3 dph(-e.x() * std::sin(th) * std::sin(ph), e.y() * std::sin(th) * std::cos(ph), 0);
        area += dth.cross(dph).norm();
      }
    }
    area *= (kPi / nt) * (2 * kPi / np);
    EXPECT_NEAR(SurfaceArea(Ellipsoid(e.x(), e.y(), e.z())), area, 1e-6 * area) << e.transpose();
  }
}

TEST(AnalyticDistance, BoxSphereCapsuleCylinderExactValues) {
  Vec3 n;
  const ShapeDesc box = Box(1, 2, 3);
  EXPECT_DOUBLE_EQ(AnalyticDistance(box, Vec3(0.5, 0, 0), &n), -0.5);
  EXPECT_EQ(n, Vec3(1, 0, 0));
  EXPECT_NEAR(AnalyticDistance(box, Vec3(0, -1.9, 0.5), &n), -0.1, 1e-15);
  EXPECT_EQ(n, Vec3(0, -1, 0));
  EXPECT_DOUBLE_EQ(AnalyticDistance(box, Vec3(0, 0, 4), &n), 1.0);
  EXPECT_EQ(n, Vec3(0, 0, 1));
  EXPECT_DOUBLE_EQ(AnalyticDistance(box, Vec3(2, -3, 0), &n), std::sqrt(2.0));
  EXPECT_TRUE(n.isApprox(Vec3(1, -1, 0).normalized(), 1e-15));
  EXPECT_DOUBLE_EQ(AnalyticDistance(box, Vec3(2, 3, 4), &n), std::sqrt(3.0));
  EXPECT_EQ(AnalyticDistance(box, Vec3(1, 0.3, -0.2), &n), 0.0);
  EXPECT_EQ(n, Vec3(1, 0, 0));

  EXPECT_DOUBLE_EQ(AnalyticDistance(Sphere(2), Vec3(0, 3, 4), &n), 3.0);
  EXPECT_TRUE(n.isApprox(Vec3(0, 0.6, 0.8), 1e-15));
  EXPECT_DOUBLE_EQ(AnalyticDistance(Sphere(2), Vec3(0, 0, 0), &n), -2.0);
  EXPECT_DOUBLE_EQ(n.norm(), 1.0);

  const ShapeDesc cap = Capsule(1, 2);
  EXPECT_DOUBLE_EQ(AnalyticDistance(cap, Vec3(3, 0, 1.5), &n), 2.0);
  EXPECT_EQ(n, Vec3(1, 0, 0));
  EXPECT_DOUBLE_EQ(AnalyticDistance(cap, Vec3(0, 0, 5), &n), 2.0);
  EXPECT_EQ(n, Vec3(0, 0, 1));
  EXPECT_DOUBLE_EQ(AnalyticDistance(cap, Vec3(0, 0.5, -2.0), &n), -0.5);
  EXPECT_EQ(n, Vec3(0, 1, 0));
  EXPECT_DOUBLE_EQ(AnalyticDistance(cap, Vec3(3, 0, 6), &n), 4.0);
  EXPECT_TRUE(n.isApprox(Vec3(0.6, 0, 0.8), 1e-15));

  const ShapeDesc cyl = Cylinder(1, 2);
  EXPECT_DOUBLE_EQ(AnalyticDistance(cyl, Vec3(0, 0, 5), &n), 3.0);
  EXPECT_EQ(n, Vec3(0, 0, 1));
  EXPECT_DOUBLE_EQ(AnalyticDistance(cyl, Vec3(0, -4, 0), &n), 3.0);
  EXPECT_EQ(n, Vec3(0, -1, 0));
  EXPECT_DOUBLE_EQ(AnalyticDistance(cyl, Vec3(4, 0, -6), &n), 5.0);  // beyond the rim
  EXPECT_TRUE(n.isApprox(Vec3(0.6, 0, -0.8), 1e-15));
  EXPECT_NEAR(AnalyticDistance(cyl, Vec3(0.5, 0, 1.9), &n), -0.1, 1e-15);  // nearest the cap
  EXPECT_EQ(n, Vec3(0, 0, 1));
  EXPECT_DOUBLE_EQ(AnalyticDistance(cyl, Vec3(0.5, 0, 0.2), &n), -0.5);  // nearest the side
  EXPECT_EQ(n, Vec3(1, 0, 0));

  ShapeDesc mesh;
  mesh.type = EShape::Mesh;
  EXPECT_TRUE(std::isnan(AnalyticDistance(mesh, Vec3::Zero(), &n)));
  EXPECT_TRUE(std::isnan(AnalyticDistance(Sphere(0), Vec3::Zero(), &n)));
}

TEST(AnalyticDistance, EllipsoidClosestPointIsExact) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Vec3& e : {Vec3(0.008, 0.008, 0.011), Vec3(0.012, 0.007, 0.004), Vec3(0.004, 0.01, 0.006)}) {
    const ShapeDesc s = Ellipsoid(e.x(), e.y(), e.z());
    double worst_on = 0, worst_par = 0;
    for (int k = 0; k < 20000; ++k) {
      // a point within a few mm of the surface (inside and outside)
      Vec3 dir(u(rng), u(rng), u(rng));
      if (k % 7 == 0) dir.x() = 0;  // some on the symmetry planes
      if (k % 11 == 0) dir.z() = 0;
      if (dir.norm() < 1e-3) continue;
      const Vec3 on = dir.normalized().cwiseProduct(e);
      Vec3 g = on.cwiseQuotient(e.cwiseProduct(e)).normalized();
      const double offset = 0.003 * u(rng);
      const Vec3 p = on + offset * g;
      Vec3 n;
      const double d = AnalyticDistance(s, p, &n);
      // the closest point lies on the ellipsoid and p - c is along its normal
      const Vec3 c = p - d * n;
      worst_on = std::max(worst_on, std::abs(c.cwiseQuotient(e).norm() - 1) * e.minCoeff());
      const Vec3 gc = c.cwiseQuotient(e.cwiseProduct(e)).normalized();
      worst_par = std::max(worst_par, (gc - n).norm());
      // when p was pushed outward along the normal by less than the inner
      // curvature radius, that foot point is the closest one
      if (offset > 0) {
        ASSERT_NEAR(d, offset, 1e-12) << p.transpose();
        ASSERT_LT((n - g).norm(), 1e-9);
      }
    }
    EXPECT_LT(worst_on, 1e-15) << e.transpose();
    EXPECT_LT(worst_par, 1e-12) << e.transpose();
  }
}

TEST(AnalyticDistance, EllipsoidAgreesWithBruteForceAndSphere) {
  const ShapeDesc s = Ellipsoid(0.012, 0.007, 0.004);
  // brute force over a fine parametric sampling for a few points, inside and outside
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 12; ++k) {
    const Vec3 p(0.014 * u(rng), 0.009 * u(rng), 0.006 * u(rng));
    const double d = AnalyticDistance(s, p);
    double best = std::numeric_limits<double>::infinity();
    const int n = 800;
    for (int i = 0; i <= n; ++i) {
      const double th = kPi * i / n;
      for (int j = 0; j < 2 * n; ++j) {
        const double ph = kPi * j / n;
        const Vec3 q(0.012 * std::sin(th) * std::cos(ph), 0.007 * std::sin(th) * std::sin(ph), 0.004 * std::cos(th));
        best = std::min(best, (q - p).norm());
      }
    }
    EXPECT_LE(std::abs(d), best + 1e-15) << p.transpose();
    EXPECT_NEAR(std::abs(d), best, 5e-5) << p.transpose();  // parametric grid resolution
    const Vec3 q = p.cwiseQuotient(s.semi_axes);
    EXPECT_EQ(d < 0, q.squaredNorm() < 1) << p.transpose();
  }
  // centre: the nearest point is the end of the shortest axis
  Vec3 n;
  EXPECT_DOUBLE_EQ(AnalyticDistance(s, Vec3::Zero(), &n), -0.004);
  EXPECT_DOUBLE_EQ(std::abs(n.z()), 1.0);
  // equal axes: a sphere
  const ShapeDesc round = Ellipsoid(0.01, 0.01, 0.01);
  for (int k = 0; k < 100; ++k) {
    const Vec3 p(0.02 * u(rng), 0.02 * u(rng), 0.02 * u(rng));
    EXPECT_NEAR(AnalyticDistance(round, p, &n), p.norm() - 0.01, 1e-16);
    EXPECT_LT((n - p.normalized()).norm(), 1e-12);
  }
}

TEST(MeanSpacing, SquareLattice) {
  PointCloud c;
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 20; ++j) c.positions.push_back(Vec3(0.002 * i, 0.002 * j, 0.5));
  EXPECT_NEAR(MeanSpacing(c), 0.002, 1e-15);
  PointCloud two;
  two.positions = {Vec3(0, 0, 0), Vec3(3, 4, 0)};
  EXPECT_DOUBLE_EQ(MeanSpacing(two), 5.0);
  PointCloud one;
  one.positions = {Vec3(1, 2, 3)};
  EXPECT_EQ(MeanSpacing(one), 0.0);
  PointCloud dup;
  dup.positions = {Vec3(1, 1, 1), Vec3(1, 1, 1), Vec3(4, 5, 1)};
  EXPECT_NEAR(MeanSpacing(dup), 5.0 / 3.0, 1e-15);
}

// ---------------------------------------------------------------------------
// meshes

// the cube [-h, h]^3 as 12 outward triangles
TriangleMesh CubeMesh(double h) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.push_back(Vec3(i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h));
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back(Eigen::Vector3i(q[0], q[1], q[2]));
    m.triangles.push_back(Eigen::Vector3i(q[0], q[2], q[3]));
  }
  return m;
}

TEST(ValidateAndOrientMesh, ClosedCubeIsOkAndKeptAsIs) {
  TriangleMesh m = CubeMesh(1.0);
  const TriangleMesh before = m;
  MeshCheckReport rep;
  EXPECT_EQ(ValidateAndOrientMesh(&m, &rep), EMeshError::None);
  EXPECT_FALSE(rep.flipped);
  EXPECT_DOUBLE_EQ(rep.volume, 8.0);
  EXPECT_DOUBLE_EQ(SignedVolume(m), 8.0);
  EXPECT_DOUBLE_EQ(SurfaceArea(m), 24.0);
  EXPECT_EQ(m.triangles, before.triangles);
  // every face normal points away from the centre
  for (const auto& t : m.triangles) {
    const Vec3 n = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
    EXPECT_GT(n.dot(m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]), 0);
  }
}

TEST(ValidateAndOrientMesh, InvertedCubeGetsFlipped) {
  TriangleMesh m = CubeMesh(0.5);
  for (auto& t : m.triangles) std::swap(t[0], t[1]);
  EXPECT_DOUBLE_EQ(SignedVolume(m), -1.0);
  MeshCheckReport rep;
  EXPECT_EQ(ValidateAndOrientMesh(&m, &rep), EMeshError::None);
  EXPECT_TRUE(rep.flipped);
  EXPECT_DOUBLE_EQ(SignedVolume(m), 1.0);
  // the two-argument-free overload does the same
  for (auto& t : m.triangles) std::swap(t[0], t[1]);
  EXPECT_EQ(ValidateAndOrientMesh(&m), EMeshError::None);
  EXPECT_DOUBLE_EQ(SignedVolume(m), 1.0);
}

TEST(ValidateAndOrientMesh, OpenBoxIsOpen) {
  TriangleMesh m = CubeMesh(1.0);
  m.triangles.resize(10);  // drop the last face (two triangles)
  const TriangleMesh before = m;
  MeshCheckReport rep;
  EXPECT_EQ(ValidateAndOrientMesh(&m, &rep), EMeshError::Open);
  EXPECT_EQ(rep.count, 4);  // the square's four edges
  EXPECT_EQ(m.triangles, before.triangles);
}

TEST(ValidateAndOrientMesh, ThreeTrianglesOnAnEdgeAreNonManifold) {
  TriangleMesh fan;
  fan.vertices = {Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-1, -1, 0)};
  fan.triangles = {Eigen::Vector3i(0, 1, 2), Eigen::Vector3i(1, 0, 3), Eigen::Vector3i(0, 1, 4)};
  MeshCheckReport rep;
  EXPECT_EQ(ValidateAndOrientMesh(&fan, &rep), EMeshError::NonManifold);
  EXPECT_EQ(rep.count, 1);
  // a closed cube with a fin on one of its edges
  TriangleMesh m = CubeMesh(1.0);
  m.vertices.push_back(Vec3(3, 3, 0));
  m.triangles.push_back(Eigen::Vector3i(0, 1, 8));
  EXPECT_EQ(ValidateAndOrientMesh(&m, &rep), EMeshError::NonManifold);
  EXPECT_EQ(rep.first, 1);  // triangle (0, 3, 1) is the first on edge 0-1
}

TEST(ValidateAndOrientMesh, BadInputs) {
  MeshCheckReport rep;
  TriangleMesh empty;
  EXPECT_EQ(ValidateAndOrientMesh(&empty, &rep), EMeshError::Empty);
  TriangleMesh no_tris = CubeMesh(1);
  no_tris.triangles.clear();
  EXPECT_EQ(ValidateAndOrientMesh(&no_tris), EMeshError::Empty);
  EXPECT_EQ(ValidateAndOrientMesh(nullptr), EMeshError::Empty);

  TriangleMesh nan = CubeMesh(1);
  nan.vertices[5].y() = std::nan("");
  EXPECT_EQ(ValidateAndOrientMesh(&nan, &rep), EMeshError::NotFinite);
  EXPECT_EQ(rep.first, 5);
  EXPECT_EQ(rep.count, 1);

  TriangleMesh bad_index = CubeMesh(1);
  bad_index.triangles[7][2] = 8;
  bad_index.triangles[9][0] = -1;
  EXPECT_EQ(ValidateAndOrientMesh(&bad_index, &rep), EMeshError::IndexOutOfRange);
  EXPECT_EQ(rep.count, 2);
  EXPECT_EQ(rep.first, 7);

  TriangleMesh degenerate = CubeMesh(1);
  degenerate.triangles[3][2] = degenerate.triangles[3][1];
  EXPECT_EQ(ValidateAndOrientMesh(&degenerate, &rep), EMeshError::Degenerate);
  EXPECT_EQ(rep.first, 3);

  // two triangles back to back: closed but encloses nothing
  TriangleMesh flat;
  flat.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  flat.triangles = {Eigen::Vector3i(0, 1, 2), Eigen::Vector3i(0, 2, 1)};
  EXPECT_EQ(ValidateAndOrientMesh(&flat, &rep), EMeshError::Degenerate);
  EXPECT_EQ(rep.count, 0);

  // one face wound the wrong way
  TriangleMesh inconsistent = CubeMesh(1);
  std::swap(inconsistent.triangles[4][1], inconsistent.triangles[4][2]);
  EXPECT_EQ(ValidateAndOrientMesh(&inconsistent, &rep), EMeshError::Inconsistent);
  EXPECT_EQ(rep.count, 3);
  for (EMeshError e : {EMeshError::None, EMeshError::Empty, EMeshError::Open, EMeshError::Inconsistent})
    EXPECT_STRNE(ToString(e), "");
}

TEST(SampleMesh, CubeMeshSamplesLieOnTheCubeWithFaceNormals) {
  TriangleMesh m = CubeMesh(0.03);
  for (auto& t : m.triangles) std::swap(t[0], t[1]);  // inward: validation must fix it
  ASSERT_EQ(ValidateAndOrientMesh(&m), EMeshError::None);
  const ShapeDesc box = Box(0.03, 0.03, 0.03);
  PointCloud c;
  ASSERT_TRUE(SampleMesh(m, 3000, 5, &c));
  ASSERT_EQ(c.size(), 3000u);
  for (size_t i = 0; i < c.size(); ++i) {
    EXPECT_LT(std::abs(AnalyticDistance(box, c.positions[i])), 1e-17);
    EXPECT_TRUE(IsFaceNormalAt(box, c.positions[i], c.normals[i].array().round().matrix()));
    EXPECT_LT((c.normals[i] - c.normals[i].array().round().matrix()).norm(), 1e-15);
  }
  const double spacing = MeanSpacing(c);
  EXPECT_GT(Measure(c.positions, spacing).Ratio(), 0.75);
  EXPECT_LT(CoverageGap(box, c, spacing, 100000), 1.5 * spacing);
  PointCloud again;
  ASSERT_TRUE(SampleMesh(m, 3000, 5, &again));
  EXPECT_EQ(again.positions, c.positions);
  // the random candidates are area-uniform over the triangles: +x face gets 1/6
  ASSERT_TRUE(SampleMeshRandom(m, 120000, 2, &c));
  int plus_x = 0;
  for (size_t i = 0; i < c.size(); ++i) plus_x += c.normals[i].x() > 0.5;
  EXPECT_NEAR(plus_x / 120000.0, 1.0 / 6.0, 5 * std::sqrt(0.25 / 120000));
}

TEST(SampleMesh, RejectsBadMeshes) {
  PointCloud c;
  c.positions.assign(2, Vec3::Zero());
  TriangleMesh empty;
  EXPECT_FALSE(SampleMesh(empty, 100, 1, &c));
  EXPECT_EQ(c.size(), 0u);
  TriangleMesh m = CubeMesh(1);
  EXPECT_FALSE(SampleMesh(m, 3, 1, &c));
  m.triangles[0][0] = 99;
  EXPECT_FALSE(SampleMesh(m, 100, 1, &c));
  TriangleMesh flat;
  flat.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};
  flat.triangles = {Eigen::Vector3i(0, 1, 2)};
  EXPECT_FALSE(SampleMesh(flat, 100, 1, &c));
}

}  // namespace
}  // namespace gs
