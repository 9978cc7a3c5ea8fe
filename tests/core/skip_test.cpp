// A scene pays only for what it uses (docs/skip.md): each skip is checked by
// the work the step reports in StepProfile::work, against the same scene with
// the feature, so that removing the skip makes the test fail.
#include <gtest/gtest.h>

#include <cstdio>

#include <cmath>

#include "core/world.h"
#include "soft_bodies.h"

namespace gs {
namespace {

using test::AddPlane;

BodySpec Ball(const Vec3& at, bool deformable) { return test::SoftBall(at, deformable); }

BodySpec Box(const Vec3& at, double half) { return test::SmallBox("box", at, half); }

// a row of resting boxes on a plane, friction mu
void RestingBoxes(World& w, double mu) {
  w.params.dt = 1e-3;
  w.params.default_friction = mu;
  w.params.solver.tolerance = 1e-7;
  w.params.solver.max_iterations = 200;
  AddPlane(w);
  for (int i = 0; i < 3; ++i) ASSERT_GE(AddBody(w, Box(Vec3(0.05 * i, 0, 0.0101), 0.01)), 0);
  w.Finalize();
}

double NormalForceSum(const World& w) {
  double s = 0.0;
  for (const ContactRow& r : w.rows) s += r.r[0];
  return s;
}

TEST(Skip, FrictionlessSceneSolvesNormalsOnly) {
  World w;
  RestingBoxes(w, 0.0);
  for (int i = 0; i < 200; ++i) {
    w.Step();
    ASSERT_FALSE(w.profile.rejected);
  }
  ASSERT_GT(w.rows.size(), 10u);
  EXPECT_EQ(w.profile.work.local_solves_3d, 0);
  EXPECT_GE(w.profile.work.local_solves_normal, static_cast<int>(w.rows.size()));
  EXPECT_TRUE(w.profile.converged);
  EXPECT_LE(w.profile.residual, w.params.solver.tolerance);
  for (const ContactRow& r : w.rows) {
    EXPECT_EQ(r.r[1], 0.0);
    EXPECT_EQ(r.r[2], 0.0);
    EXPECT_GE(r.r[0], 0.0);
  }
  // the boxes' weight is carried (3 x 0.05 kg)
  EXPECT_NEAR(NormalForceSum(w), 3 * 0.05 * 9.81, 0.02 * 3 * 0.05 * 9.81);
}

TEST(Skip, NormalsOnlyAgreesWithTheFullSolverAtVanishingFriction) {
  World a, b;
  RestingBoxes(a, 0.0);
  RestingBoxes(b, 1e-12);  // the general 3D solver on (almost) the same problem
  for (int i = 0; i < 150; ++i) {
    a.Step();
    b.Step();
  }
  EXPECT_EQ(b.profile.work.local_solves_normal, 0);
  EXPECT_GT(b.profile.work.local_solves_3d, 0);
  ASSERT_EQ(a.rows.size(), b.rows.size());
  for (size_t i = 1; i < a.bodies.size(); ++i)
    EXPECT_LT((a.bodies[i].pose.t - b.bodies[i].pose.t).norm(), 1e-7) << "body " << i;
  EXPECT_NEAR(NormalForceSum(a), NormalForceSum(b), 1e-3 * NormalForceSum(b));
}

TEST(Skip, FrictionUsesTheFullSolver) {
  World w;
  RestingBoxes(w, 0.5);
  for (int i = 0; i < 50; ++i) w.Step();
  EXPECT_EQ(w.profile.work.local_solves_normal, 0);
  EXPECT_GT(w.profile.work.local_solves_3d, 0);
}

// a ball resting on a plane, deformable or rigid
void BallOnPlane(World& w, bool deformable) {
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-7;
  w.params.solver.max_iterations = 200;
  AddPlane(w);
  ASSERT_GE(AddBody(w, Ball(Vec3(0, 0, 0.0101), deformable)), 0);
  w.Finalize();
}

TEST(Skip, RigidBodiesHaveNoDeformationWork) {
  World rigid, soft;
  BallOnPlane(rigid, false);
  BallOnPlane(soft, true);
  for (int i = 0; i < 100; ++i) {
    rigid.Step();
    soft.Step();
  }
  ASSERT_GT(rigid.rows.size(), 0u);
  ASSERT_GT(soft.rows.size(), 0u);
  const StepWork& r = rigid.profile.work;
  EXPECT_EQ(r.w_deform_sides, 0);
  EXPECT_EQ(r.propagations, 0);
  EXPECT_EQ(r.deformed_points, 0);
  EXPECT_EQ(r.refit_trees, 0);
  EXPECT_EQ(r.refit_nodes, 0);
  EXPECT_GT(r.w_blocks_built, 0);
  // the same scene with a deformable ball does all of it
  const StepWork& s = soft.profile.work;
  EXPECT_GT(s.w_deform_sides, 0);
  EXPECT_GT(s.propagations, 0);
  // the points its contacts reach (Body::live), not the whole ball's 200
  EXPECT_EQ(s.deformed_points, static_cast<int>(soft.bodies[1].live.size()));
  EXPECT_GT(s.deformed_points, 0);
  EXPECT_LT(s.deformed_points, 200);
  EXPECT_EQ(s.refit_trees, 1);
  EXPECT_GT(s.refit_nodes, 0);
}

// Only the control points a contact force can have reached are integrated; every
// other point is exactly at rest, so skipping it changes nothing: the same ball
// with every point integrated (WakeAll before each step) ends bit for bit the same.
TEST(Skip, OnlyPointsAContactReachesAreIntegrated) {
  World some, all;
  BallOnPlane(some, true);
  BallOnPlane(all, true);
  some.params.sleep.enabled = all.params.sleep.enabled = false;  // WakeAll must change nothing else
  for (int i = 0; i < 200; ++i) {
    all.WakeAll();
    some.Step();
    all.Step();
    ASSERT_FALSE(some.profile.rejected);
  }
  const Body& b = some.bodies[1];
  ASSERT_EQ(static_cast<int>(all.bodies[1].live.size()), b.deform.size());
  ASSERT_GT(b.live.size(), 0u);
  ASSERT_LT(static_cast<int>(b.live.size()), b.deform.size());
  EXPECT_EQ(all.profile.work.deformed_points, b.deform.size());
  EXPECT_EQ(some.profile.work.deformed_points, static_cast<int>(b.live.size()));
  int deformed = 0;
  for (int j = 0; j < b.deform.size(); ++j) {
    if (!b.live_mark[j]) {
      EXPECT_EQ(b.u[j], Vec3::Zero()) << "point " << j << " is not live yet displaced";
      EXPECT_EQ(b.u_acc[j], Vec3::Zero()) << "point " << j;
    }
    deformed += b.u[j] != Vec3::Zero() ? 1 : 0;
    EXPECT_EQ(b.u[j], all.bodies[1].u[j]) << "point " << j;
  }
  EXPECT_GT(deformed, 0);
  EXPECT_EQ(b.pose.t, all.bodies[1].pose.t);
  EXPECT_EQ(b.pose.R, all.bodies[1].pose.R);
}

TEST(Skip, OnlyMovedSubtreesAreRefit) {
  World w;
  BallOnPlane(w, true);
  for (int i = 0; i < 100; ++i) w.Step();
  const SphereTree& tree = w.bodies[1].geometry.tree;
  const int nodes = static_cast<int>(tree.nodes().size());
  // pressed at its bottom only: the leaves there and their ancestors, not the tree
  EXPECT_GT(w.profile.work.refit_nodes, 0);
  EXPECT_LT(w.profile.work.refit_nodes, nodes / 2) << "of " << nodes << " nodes";
  // lifted away, the deformation relaxes; once it stops changing nothing is refit
  w.bodies[1].pose = w.bodies[1].pose_prev = Pose::Translation(Vec3(0, 0, 0.5));
  w.bodies[1].velocity.setZero();
  int last_refit_step = -1;
  for (int i = 0; i < 300; ++i) {
    w.Step();
    if (w.profile.work.refit_nodes > 0) last_refit_step = i;
  }
  EXPECT_GT(last_refit_step, 0);
  EXPECT_LT(last_refit_step, 250);
  EXPECT_EQ(w.profile.work.refit_trees, 0);
  EXPECT_EQ(w.profile.work.refit_nodes, 0);
  // a deformable body moving rigidly through free space is not refit either
  EXPECT_GT(w.bodies[1].velocity.norm(), 0.1);
}

// Refit inflates a moved leaf by its control point's spread, max |u_k - u_j| over its
// influence. Constrained motion measures a spread only once the bound it keeps (the
// last measure plus twice the body's largest displacement changes since) has grown
// past a tenth of it or a hundredth of a spacing: every step, every changed point's
// spread is at least the measured one (refit stays conservative) and at most that
// allowance above it; and the bound does stand in (points not measured in a step).
TEST(Skip, KeptSpreadsBoundTheMeasuredOnesWithinTheirAllowance) {
  World w;
  BallOnPlane(w, true);
  Body& b = w.bodies[1];
  const double floor = 0.01 * b.deform.spacing();
  int64_t checked = 0, kept = 0, measured = 0;
  double worst_over = 0.0;
  for (int i = 0; i < 400; ++i) {
    if (i == 100) {  // lifted away: the whole deformation relaxes
      b.pose = b.pose_prev = Pose::Translation(Vec3(0, 0, 0.5));
      b.velocity.setZero();
    }
    w.Step();
    for (int j : b.live) {
      if (!b.u_changed[j]) continue;
      const int* idx;
      const double* phi;
      const int n = b.deform.Influence(j, &idx, &phi);
      double exact = 0.0;
      for (int k = 0; k < n; ++k) exact = std::max(exact, (b.u[idx[k]] - b.u[j]).norm());
      ++checked;
      (b.spread_mark[j] == b.spread_slack ? measured : kept) += 1;
      ASSERT_GE(b.u_spread[j], exact * (1.0 - 1e-12)) << "step " << i << " point " << j;
      const double over = b.u_spread[j] - exact;
      worst_over = std::max(worst_over, over / std::max(0.1 * exact, floor));
      ASSERT_LE(over, 2.0 * std::max(0.1 * exact, floor) + 1e-15) << "step " << i << " point " << j;
    }
  }
  EXPECT_GT(checked, 1000);
  EXPECT_GT(kept, measured) << "the bound should stand in for most measures";
  EXPECT_GT(measured, 0);
  std::printf("spreads: %lld checked, %lld kept, %lld measured; most over the measure: %.2f allowances\n",
              static_cast<long long>(checked), static_cast<long long>(kept), static_cast<long long>(measured),
              worst_over);
}

// the soft ball resting on the fixed soft slab: every contact has a side
// interpolated over several control points of the other body's surface
void BallOnSlab(World& w) {
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-7;
  w.params.solver.max_iterations = 200;
  // the yardsticks below (the effect of the solver's tolerance on a rattling ball)
  // are set on Siconos' measure, looser on this light ball than the step's default
  w.params.solver.measure = EStopMeasure::Siconos;
  ASSERT_GE(AddBody(w, test::SoftSlab("slab")), 0);
  ASSERT_GE(AddBody(w, test::SoftBall(Vec3(0, 0, 0.0201))), 0);
  w.Finalize();
}

TEST(Skip, UnchangedContactSidesReuseTheirInfluence) {
  World on, off;
  BallOnSlab(on);
  BallOnSlab(off);
  // both reuse for 299 steps (bit-identical runs), then one step with reuse, one
  // without, from the same state: a ball resting on a flat rolls freely (its normal
  // forces act through the touching point), and over hundreds of steps the two runs'
  // round-off would grow into rolling that is not what one step's reuse changes
  for (int i = 0; i < 299; ++i) {
    on.Step();
    off.Step();
  }
  off.params.reuse_contact_space = false;
  on.Step();
  off.Step();
  ASSERT_GT(on.rows.size(), 3u);
  // the interpolated sides of the resting contacts persist from the last step and are
  // copied; the query sides stand on one control point and merge nothing at all
  const StepWork& k = on.profile.work;
  EXPECT_GT(k.w_deform_reused, 0);
  EXPECT_GT(k.w_deform_direct, 0);
  EXPECT_LE(k.w_deform_reused + k.w_deform_direct, k.w_deform_sides);
  EXPECT_EQ(off.profile.work.w_deform_reused, 0);
  EXPECT_EQ(off.profile.work.w_deform_direct, k.w_deform_direct);
  EXPECT_EQ(off.profile.work.w_deform_sides, k.w_deform_sides);
  // what is reused is what would have been recomputed, but for the eq. 8 weights kept
  // while an anchor stays within reuse_anchor_tolerance of where they were evaluated
  // (W's blocks); the ball resting on many contacts is statically indeterminate, so
  // how the load is shared among them is set only to the solver's tolerance: what
  // must agree is the load they carry together and the motion it gives
  ASSERT_EQ(on.rows.size(), off.rows.size());
  double load_on = 0, load_off = 0;
  for (size_t i = 0; i < on.rows.size(); ++i) {
    EXPECT_LT((on.rows[i].w_diag - off.rows[i].w_diag).norm(), 1e-4 * off.rows[i].w_diag.norm()) << i;
    load_on += on.rows[i].r[0];
    load_off += off.rows[i].r[0];
  }
  EXPECT_GT(load_off, 0);
  EXPECT_LT(std::abs(load_on - load_off), 1e-4 * load_off);
  EXPECT_LT((on.bodies[1].pose.t - off.bodies[1].pose.t).norm(), 1e-7);
  for (size_t j = 0; j < on.bodies[1].u.size(); ++j) ASSERT_LT((on.bodies[1].u[j] - off.bodies[1].u[j]).norm(), 1e-8);
}

// a side on one control point reads that point's influence in its model: the very
// values a merge would build (ball on a plane: every deformable side is one)
TEST(Skip, SidesOnOneControlPointMergeNothing) {
  World w;
  BallOnPlane(w, true);
  for (int i = 0; i < 150; ++i) w.Step();
  ASSERT_GT(w.rows.size(), 3u);
  EXPECT_EQ(w.profile.work.w_deform_direct, w.profile.work.w_deform_sides);
  EXPECT_TRUE(w.side_inf_idx.empty());
  const Body& ball = w.bodies[1];
  for (const ContactRow& row : w.rows) {
    const ContactSide& s = row.side[0];
    ASSERT_EQ(row.contact.body[0], 1);
    ASSERT_EQ(s.count, 1);
    const int* idx;
    const double* phi;
    const int n = ball.deform.Influence(row.contact.leaf, &idx, &phi);
    ASSERT_EQ(s.inf_count, n);
    for (int m = 0; m < n; ++m) {
      ASSERT_EQ(s.inf_idx[m], idx[m]);
      ASSERT_EQ(s.inf_phi[m], phi[m]);
    }
    EXPECT_EQ(s.w_deform, ball.deform.SelfCompliance(row.contact.leaf));
  }
}

TEST(Skip, DistantPairsCostOneSphereTest) {
  World w;
  w.params.dt = 1e-3;
  AddPlane(w);
  // eight balls falling side by side, 5 cm apart, high above the plane
  for (int i = 0; i < 8; ++i) ASSERT_GE(AddBody(w, Ball(Vec3(0.05 * i, 0, 0.3), true)), 0);
  // and a fixed box and a kinematic one: a pair of them is never a candidate
  BodySpec fixed = Box(Vec3(1, 1, 0.01), 0.01);
  fixed.motion = EMotion::Fixed;
  AddBody(w, fixed);
  BodySpec kin = Box(Vec3(1, 1.015, 0.01), 0.01);
  kin.motion = EMotion::Kinematic;
  AddBody(w, kin);
  w.Finalize();
  for (int i = 0; i < 5; ++i) w.Step();
  const StepWork& k = w.profile.work;
  // 11 bodies: 55 pairs; plane-fixed, plane-kinematic and fixed-kinematic cannot move
  EXPECT_EQ(k.body_pairs, 55 - 3);
  EXPECT_EQ(k.pair_tests, k.body_pairs);
  EXPECT_EQ(k.pairs_traversed, 0);
  EXPECT_EQ(w.profile.collision.node_pairs, 0);
  EXPECT_EQ(w.rows.size(), 0u);
  // closer than their bounding spheres, two of them are traversed
  World v;
  v.params.dt = 1e-3;
  AddPlane(v);
  ASSERT_GE(AddBody(v, Ball(Vec3(0, 0, 0.3), true)), 0);
  ASSERT_GE(AddBody(v, Ball(Vec3(0.0205, 0, 0.3), true)), 0);
  v.Finalize();
  v.Step();
  EXPECT_EQ(v.profile.work.pairs_traversed, 1);
  EXPECT_GT(v.profile.collision.node_pairs, 0);
}

}  // namespace
}  // namespace gs
