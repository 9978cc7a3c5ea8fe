// Pairs proven apart (CollisionParams::skip_clear_pairs, PairStaysClear): a body pair
// whose last detection found no contact and proved every control point farther than
// the threshold by more than the bodies have moved since is not detected. Skipping it
// must change nothing: detection at the same poses finds no contact in any step that
// skipped, and a ball dropped onto a slab lands in the same step and moves the same
// with the skip as without. A point whose projection proves nothing is proven apart
// by its distance to the other tree's leaf spheres (SphereDistanceBound), a lower
// bound on its distance to that surface.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/world.h"
#include "soft_bodies.h"

namespace gs {
namespace {

// the soft ball 3 mm over the soft slab's top, falling onto it
int DroppedBall(World& w, bool skip) {
  w.params.collision.skip_clear_pairs = skip;
  EXPECT_GE(AddBody(w, test::SoftSlab("slab")), 0);
  const int ball = AddBody(w, test::SoftBall(Vec3(0.001, -0.002, 0.01 + 0.01 + 3e-3)));
  EXPECT_GE(ball, 0);
  w.Finalize();
  return ball;
}

TEST(ClearPairs, ASkippedPairHasNoContactAtThoseVeryPoses) {
  World w;
  DroppedBall(w, true);
  int skipped = 0, first_contact = -1;
  for (int i = 0; i < 60; ++i) {
    w.Step();
    if (first_contact < 0 && w.profile.contacts > 0) first_contact = i;
    if (w.profile.work.pairs_clear == 0) continue;
    ++skipped;
    EXPECT_EQ(w.profile.contacts, 0) << "step " << i;
    // detection of the same poses, nothing skipped
    w.params.collision.skip_clear_pairs = false;
    DetectCollisions(w);
    EXPECT_EQ(w.contacts.items.size(), 0u) << "step " << i << ": a skipped pair touches";
    w.params.collision.skip_clear_pairs = true;
  }
  EXPECT_GT(skipped, 3) << "the falling ball's pair was never proven apart";
  EXPECT_GT(first_contact, 0) << "the ball never landed";
}

TEST(ClearPairs, TheBallLandsAndMovesAsWithDetectionInEveryStep) {
  World skip, every;
  const int b_skip = DroppedBall(skip, true);
  const int b_every = DroppedBall(every, false);
  int skipped = 0, landed_skip = -1, landed_every = -1;
  double worst = 0.0;
  for (int i = 0; i < 100; ++i) {
    skip.Step();
    every.Step();
    skipped += skip.profile.work.pairs_clear;
    EXPECT_EQ(every.profile.work.pairs_clear, 0);
    if (landed_skip < 0 && skip.profile.contacts > 0) landed_skip = i;
    if (landed_every < 0 && every.profile.contacts > 0) landed_every = i;
    const Vec3 d = skip.bodies[b_skip].pose.t - every.bodies[b_every].pose.t;
    if (landed_every < 0) {
      // in the air both steps are the same free fall, bit for bit
      EXPECT_EQ(d.norm(), 0.0) << "step " << i;
    }
    worst = std::max(worst, d.norm());
  }
  EXPECT_GT(skipped, 3);
  ASSERT_GE(landed_every, 0);
  EXPECT_EQ(landed_skip, landed_every);
  // after landing the projections may start from other feet (the far memory of the
  // skipped steps), each within the MLS tolerance: the paths stay within 0.1 um
  EXPECT_LT(worst, 1e-7);
}

// Around the soft ball (1 cm radius) and the slab, points from one leaf radius inside
// to three outside: the
// bound never exceeds the distance to the MLS surface (the foot of the projection
// over all the body's points), and it is not trivial: within one leaf sphere's
// diameter of it.
TEST(ClearPairs, SphereDistanceBoundIsALowerBoundOnTheDistanceToTheSurface) {
  World w;
  const int slab = AddBody(w, test::SoftSlab("slab"));
  const int ball = AddBody(w, test::SoftBall(Vec3(0.0, 0.0, 0.05)));
  ASSERT_GE(slab, 0);
  ASSERT_GE(ball, 0);
  w.Finalize();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const int id : {ball, slab}) {
    const CollisionShape shape = w.bodies[id].Shape();
    const SphereTree& t = *shape.tree;
    const PointCloud& cloud = *shape.cloud;
    CollisionScratch s;
    s.Reserve(t.num_leaves(), 1024);
    double widest = 0.0;
    for (int l = 0; l < t.num_leaves(); ++l) widest = std::max(widest, t.node(t.leaf_node(l)).rest_radius);
    std::vector<int> all(cloud.positions.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
    int outside = 0;
    for (int k = 0; k < 200; ++k) {
      // a surface sample moved along its normal by -1 .. 3 leaf radii and sideways by half of one
      const int i = static_cast<int>((unit(rng) + 1.0) * 0.5 * (cloud.positions.size() - 1));
      const Vec3 side(unit(rng), unit(rng), unit(rng));
      const Vec3 x = cloud.positions[i] + widest * ((1.0 + 2.0 * unit(rng)) * cloud.normals[i] + 0.5 * side);
      const double bound = SphereDistanceBound(t, x, &s);
      ASSERT_TRUE(std::isfinite(bound));
      MlsProjection proj;
      if (!ProjectOntoSurface(cloud.positions.data(), cloud.normals.data(), all.data(), static_cast<int>(all.size()),
                              x, shape.mls, &proj) ||
          !proj.converged)
        continue;
      const double dist = (x - proj.point).norm();
      EXPECT_LE(bound, dist + 1e-9) << "body " << id << " point " << k;
      EXPECT_GE(bound, dist - 2.0 * widest) << "body " << id << " point " << k;
      outside += bound > 0.0 ? 1 : 0;
    }
    EXPECT_GT(outside, 20) << "body " << id << ": the bound proved no point outside a leaf sphere";
  }
}

}  // namespace
}  // namespace gs
