#include "core/sphere_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/body_geometry.h"
#include "core/point_grid.h"
#include "shapes.h"

namespace gs {
namespace {

BodyGeometry MakeGeometry(const ShapeDesc& shape, int points, int control_points) {
  BodyGeometry g;
  GeometryOptions opt;
  opt.points = points;
  opt.control_points = control_points;
  opt.seed = 3;
  EXPECT_EQ(BuildShapeGeometry(shape, opt, &g), EGeometryError::None);
  return g;
}

// every point belongs to exactly one leaf, every node bounds its points
void CheckStructure(const BodyGeometry& g, int leaves) {
  const SphereTree& t = g.tree;
  ASSERT_EQ(t.num_leaves(), leaves);
  ASSERT_EQ(static_cast<int>(t.nodes().size()), 2 * leaves - 1);
  std::vector<int> seen(g.cloud.size(), 0);
  for (size_t ni = 0; ni < t.nodes().size(); ++ni) {
    const TreeNode& n = t.node(static_cast<int>(ni));
    EXPECT_EQ(t.radius(static_cast<int>(ni)), n.rest_radius);  // not grown yet
    for (int k = n.first; k < n.first + n.count; ++k) {
      const int i = t.point_order()[k];
      EXPECT_LE((g.cloud.positions[i] - n.center).norm(), n.rest_radius + 1e-12);
      if (n.IsLeaf()) ++seen[i];
    }
    if (!n.IsLeaf()) {
      EXPECT_EQ(t.node(n.child[0]).count + t.node(n.child[1]).count, n.count);
      EXPECT_EQ(t.node(n.child[0]).parent, &n - t.nodes().data());
    }
  }
  for (size_t i = 0; i < seen.size(); ++i) ASSERT_EQ(seen[i], 1) << "point " << i;
  // depth-first layout: the left child follows its parent, a subtree is a node range
  for (int i = 0; i < static_cast<int>(t.nodes().size()); ++i) {
    const TreeNode& n = t.node(i);
    if (n.IsLeaf()) {
      EXPECT_EQ(t.span_end()[i], i + 1);
    } else {
      EXPECT_EQ(n.child[0], i + 1);
      EXPECT_EQ(n.child[1], t.span_end()[n.child[0]]);
      EXPECT_EQ(t.span_end()[i], t.span_end()[n.child[1]]);
    }
  }
  for (int l = 0; l < leaves; ++l) EXPECT_EQ(t.node(t.leaf_node(l)).leaf, l);
}

// dense points of the MLS surface must each lie inside some leaf sphere
void CheckCoverage(const BodyGeometry& g, const ShapeDesc& shape, int samples) {
  const SphereTree& t = g.tree;
  PointGrid leaf_grid;
  leaf_grid.Build(t.control_points(), 2 * g.spacing);
  double max_r = 0;
  for (int l = 0; l < t.num_leaves(); ++l) max_r = std::max(max_r, t.radius(t.leaf_node(l)));
  PointGrid grid;
  grid.Build(g.cloud.positions, 2 * g.spacing);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> nd;
  std::vector<int> nbrs, leaves;
  int uncovered = 0, projected = 0;
  for (int s = 0; s < samples; ++s) {
    // a random direction from the centre, pushed onto the analytic surface, then onto the MLS surface
    Vec3 d(nd(rng), nd(rng), nd(rng));
    d.normalize();
    Vec3 p = d * 0.02;
    Vec3 normal;
    for (int it = 0; it < 50; ++it) p -= AnalyticDistance(shape, p, &normal) * normal;
    nbrs.clear();
    grid.Query(p, g.mls.support * g.mls.bandwidth, &nbrs);
    MlsProjection proj;
    if (nbrs.empty() || !MlsProject(g.cloud.positions.data(), g.cloud.normals.data(), nbrs.data(),
                                    static_cast<int>(nbrs.size()), p, g.mls, &proj))
      continue;
    ++projected;
    leaves.clear();
    leaf_grid.Query(proj.point, max_r, &leaves);
    bool inside = false;
    for (int l : leaves) inside |= (proj.point - t.control_point(l)).norm() <= t.radius(t.leaf_node(l));
    uncovered += !inside;
  }
  EXPECT_GT(projected, samples * 9 / 10);
  EXPECT_EQ(uncovered, 0);
}

TEST(SphereTree, EllipsoidFingertipStructureAndCoverage) {
  const ShapeDesc shape = test::FingertipEllipsoid();
  const BodyGeometry g = MakeGeometry(shape, 2400, 320);
  CheckStructure(g, 320);
  CheckCoverage(g, shape, 20000);
}

TEST(SphereTree, PaperBoxStructureAndCoverage) {
  const ShapeDesc shape = test::CubeShape(0.06);
  const BodyGeometry g = MakeGeometry(shape, 36000, 4800);
  CheckStructure(g, 4800);
  CheckCoverage(g, shape, 40000);
}

// A thin slab (16 x 8 x 1 cm): once a column of it is narrower than it is thick, a
// split by count alone cut through one face, and 77 of 3,000 leaves held points of
// both faces (opposite normals, a sphere across the slab). Away from the side
// faces every leaf now lies on one face.
TEST(SphereTree, NoLeafOfAThinSlabHoldsBothFaces) {
  ShapeDesc slab;
  slab.type = EShape::Box;
  slab.half_extents = Vec3(0.08, 0.04, 0.005);
  const BodyGeometry g = MakeGeometry(slab, 24000, 3000);
  CheckStructure(g, 3000);
  int interior = 0;
  for (int l = 0; l < g.tree.num_leaves(); ++l) {
    const Vec3 c = g.tree.control_point(l);
    if (std::abs(c.x()) > 0.075 || std::abs(c.y()) > 0.035) continue;  // leaves by a side face may bend
    ++interior;
    EXPECT_GT(g.tree.leaf_flatness(l), 0.9986) << "leaf " << l << " at " << c.transpose();
    // a leaf holding both faces reaches at least half the thickness from its centre
    EXPECT_LT(g.tree.node(g.tree.leaf_node(l)).rest_radius, 0.005) << "leaf " << l;
  }
  EXPECT_GT(interior, 2000);
}

TEST(SphereTree, ControlPointsLieOnTheSurface) {
  const ShapeDesc shape = test::FingertipEllipsoid();
  const BodyGeometry g = MakeGeometry(shape, 2400, 320);
  for (int l = 0; l < g.tree.num_leaves(); ++l) {
    const double d = AnalyticDistance(shape, g.tree.control_point(l));
    EXPECT_LT(std::abs(d), 0.05 * g.spacing) << "leaf " << l;
  }
}

TEST(SphereTree, NeighbourhoodHoldsEveryPointWithinRadiusPlusBorder) {
  const BodyGeometry g = MakeGeometry(test::FingertipEllipsoid(), 2400, 320);
  for (int l = 0; l < g.tree.num_leaves(); l += 7) {
    int count = 0;
    const int* idx = g.tree.neighbourhood(l, &count);
    std::vector<int> got(idx, idx + count);
    const TreeNode& n = g.tree.node(g.tree.leaf_node(l));
    std::vector<int> want;
    for (int i = 0; i < static_cast<int>(g.cloud.size()); ++i)
      if ((g.cloud.positions[i] - n.center).norm() <= n.rest_radius + g.tree.border()) want.push_back(i);
    EXPECT_EQ(got, want);
  }
}

TEST(SphereTree, RefitTouchesOnlyDeformedSubtreesAndEnclosesTheGrowth) {
  BodyGeometry g = MakeGeometry(test::FingertipEllipsoid(), 2400, 320);
  SphereTree& t = g.tree;
  const int leaves = t.num_leaves();
  std::vector<Vec3> u(leaves, Vec3::Zero());
  std::vector<double> spread(leaves, 0.0);
  std::vector<uint8_t> changed(leaves, 0);
  // deform two leaves
  u[5] = Vec3(0, 0, -4e-4);
  u[200] = Vec3(1e-4, 0, 0);
  spread[5] = 1e-4;
  changed[5] = changed[200] = 1;
  const int stop = 3;
  RefitStats stats;
  const double height_5 = t.leaf_height(5);
  t.Refit(u.data(), spread.data(), changed.data(), stop, &stats);
  EXPECT_EQ(stats.leaves_changed, 2);
  // at most: the two leaves, their ancestors down to the stop level, and the nodes above it
  EXPECT_LE(stats.nodes_visited, 2 * (t.depth() + 1) + (1 << stop));
  std::vector<uint8_t> on_path(t.nodes().size(), 0);
  for (int l : {5, 200})
    for (int n = t.leaf_node(l); n >= 0; n = t.node(n).parent) on_path[n] = 1;
  for (size_t i = 0; i < t.nodes().size(); ++i) {
    const TreeNode& n = t.node(static_cast<int>(i));
    const double r = t.radius(static_cast<int>(i));
    if (n.depth < stop) {
      EXPECT_GE(r, n.rest_radius + 5e-4 - 1e-15);  // inflated by the largest growth
    } else if (on_path[i]) {
      EXPECT_GT(r, n.rest_radius);
    } else {
      EXPECT_EQ(r, n.rest_radius) << "node " << i << " was touched";
    }
    EXPECT_EQ(t.traversal()[i].radius, r);  // what traversal reads
  }
  EXPECT_DOUBLE_EQ(t.radius(t.leaf_node(5)), t.node(t.leaf_node(5)).rest_radius + 5e-4);
  // a leaf's height grows with its sphere
  EXPECT_DOUBLE_EQ(t.leaf_height(5), height_5 + 5e-4);
  // relaxing back shrinks the path again
  u[5].setZero();
  u[200].setZero();
  spread[5] = 0;
  t.Refit(u.data(), spread.data(), changed.data(), stop, &stats);
  for (int i = 0; i < static_cast<int>(t.nodes().size()); ++i) EXPECT_DOUBLE_EQ(t.radius(i), t.node(i).rest_radius);
  EXPECT_DOUBLE_EQ(t.leaf_height(5), height_5);
  // nothing changed: nothing visited
  std::fill(changed.begin(), changed.end(), 0);
  t.Refit(u.data(), spread.data(), changed.data(), stop, &stats);
  EXPECT_EQ(stats.nodes_visited, 0);
}

// the patch error bound, measured at build on a dozen samples per leaf, holds
// everywhere over the leaf: random points near the surface inside a leaf whose
// bound is within collision's limit (0.3% of h) project onto the MLS surface
// within twice that bound of the patch's closest point
TEST(SphereTree, PatchErrorBoundHoldsBetweenItsSamples) {
  // (shape, share of the leaves that must be bounded): a coarse cube's leaves near
  // its edges see the edge within their kernel's reach and are not trusted
  for (const auto& [shape, share] : {std::pair<ShapeDesc, double>{test::FingertipEllipsoid(), 0.5}, {test::CubeShape(0.03), 0.1}}) {
    const BodyGeometry g = MakeGeometry(shape, 2400, 320);
    const SphereTree& t = g.tree;
    const double h = g.mls.bandwidth;
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int bounded = 0, checked = 0;
    for (int l = 0; l < t.num_leaves(); ++l) {
      if (!(t.leaf_patch_error(l) <= 3e-3 * h)) continue;
      ++bounded;
      const TreeNode& node = t.node(t.leaf_node(l));
      int count = 0;
      const int* idx = t.neighbourhood(l, &count);
      for (int k = 0; k < 10; ++k) {
        const Vec3 x = node.center + 0.9 * node.rest_radius * Vec3(u(rng), u(rng), u(rng)) / std::sqrt(3.0);
        MlsProjection proj;
        ASSERT_TRUE(MlsProject(g.cloud.positions.data(), g.cloud.normals.data(), idx, count, x, g.mls, &proj));
        if ((proj.point - node.center).norm() > node.rest_radius) continue;
        ++checked;
        EXPECT_LE((proj.point - t.leaf_patch(l)->Closest(proj.point)).norm(),
                  2.0 * t.leaf_patch_error(l) + 1e-3 * h)
            << "leaf " << l;
      }
    }
    EXPECT_GT(bounded, share * t.num_leaves());
    EXPECT_GT(checked, 5 * bounded);
  }
}

TEST(SphereTree, RefusesBadInput) {
  SphereTree t;
  PointCloud c;
  MlsParams mls;
  SphereTreeParams p;
  EXPECT_EQ(t.Build(c, mls, p), SphereTree::EBuildError::TooFewPoints);
  for (int i = 0; i < 10; ++i) {
    c.positions.push_back(Vec3(i, 0, 0));
    c.normals.push_back(Vec3::UnitZ());
  }
  p.leaf_count = 11;
  EXPECT_EQ(t.Build(c, mls, p), SphereTree::EBuildError::BadLeafCount);
  p.leaf_count = 2;
  c.positions[3].x() = std::nan("");
  EXPECT_EQ(t.Build(c, mls, p), SphereTree::EBuildError::NotFinite);
}

}  // namespace
}  // namespace gs
