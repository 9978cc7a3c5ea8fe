// Contact-space reuse across steps (WorldParams::reuse_contact_space and
// reuse_anchor_tolerance): a deformable contact side whose surface anchor stays
// within the tolerance of where its eq. 8 weights were evaluated keeps them, and
// with them its merged influence and W_deform term. The results must stay within
// a tolerance far below what the scene can resolve, and the reuse must really
// happen (counted in StepWork), or this test fails.
#include <gtest/gtest.h>

#include <cmath>

#include "core/world.h"
#include "soft_bodies.h"

namespace gs {
namespace {

// a deformable ball resting on a fixed deformable box (the contacts' surface
// sides are interpolated on the box), pushed sideways by a small force
void BallOnSoftBox(World& w, double anchor_tolerance, bool reuse = true) {
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-7;
  w.params.solver.max_iterations = 300;
  // the yardsticks below (the effect of the solver's tolerance on a rattling ball)
  // are set on Siconos' measure, looser on this light ball than the step's default
  w.params.solver.measure = EStopMeasure::Siconos;
  w.params.reuse_contact_space = reuse;
  w.params.reuse_anchor_tolerance = anchor_tolerance;
  // every step's own projection: a kept foot (CollisionParams::foot_memory) keeps its
  // anchor bitwise, which the tolerance-free world would then reuse too
  w.params.collision.foot_memory = false;
  ASSERT_GE(AddBody(w, test::SoftSlab("box")), 0);
  BodySpec ball = test::SoftBall();
  ball.pose = Pose::Translation(Vec3(0, 0, 0.0201));
  ball.drive.enabled = true;  // no force unless a test sets one
  ASSERT_GE(AddBody(w, ball), 0);
  w.Finalize();
}

TEST(ContactReuse, RestingInterpolationsAreKeptWithinTolerance) {
  // on: the default tolerance; exact: reuse of bitwise-equal anchors only; off: no
  // reuse; finer: exact with half the solver tolerance, to scale what "within
  // tolerance" means for this (rattling, so chaotic) ball
  World on, exact, off, finer;
  BallOnSoftBox(on, 1e-4);
  BallOnSoftBox(exact, 0.0);
  BallOnSoftBox(off, 1e-4, false);
  BallOnSoftBox(finer, 0.0);
  finer.params.solver.tolerance *= 0.5;
  int kept = 0, interpolated = 0;
  double d_reuse = 0.0, d_solver = 0.0;
  for (int i = 0; i < 600; ++i) {
    on.Step();
    exact.Step();
    off.Step();
    finer.Step();
    for (const ContactRow& r : on.rows) interpolated += r.side[1].count > 1 ? 1 : 0;
    kept += on.profile.work.weights_reused;
    EXPECT_EQ(off.profile.work.weights_reused, 0);
    EXPECT_EQ(off.profile.work.w_deform_reused, 0);
    d_reuse = std::max(d_reuse, (on.bodies[1].pose.t - exact.bodies[1].pose.t).norm());
    d_solver = std::max(d_solver, (finer.bodies[1].pose.t - exact.bodies[1].pose.t).norm());
    // bitwise-equal anchors reuse exactly what would be recomputed: the same run as no reuse
    ASSERT_EQ(exact.bodies[1].pose.t, off.bodies[1].pose.t) << i;
  }
  ASSERT_GT(on.rows.size(), 5u);
  ASSERT_GT(interpolated, 3000);
  // anchors of resting contacts drift by ~1e-9 m per step: with the tolerance a good
  // part of the surface sides keep their interpolation; without it hardly any
  EXPECT_GT(kept, 0.3 * interpolated);
  EXPECT_LT(exact.profile.work.weights_reused * 10, on.profile.work.weights_reused + 10);
  // the same physics: kept interpolations move the ball less than halving the solver
  // tolerance does, and far less than the MLS projection resolves (~3e-6 m)
  EXPECT_GT(d_solver, 0.0);
  EXPECT_LT(d_reuse, 0.5 * d_solver);
  EXPECT_LT(d_reuse, 3e-7);
  for (const ContactRow& r : on.rows) ASSERT_TRUE(r.r.allFinite());
}

// A sliding contact moves its anchor beyond the tolerance: the weights are recomputed
// from the current anchor, not kept from where the contact started.
TEST(ContactReuse, MovingAnchorsAreReinterpolated) {
  World w;
  BallOnSoftBox(w, 1e-4);
  for (int i = 0; i < 100; ++i) w.Step();
  w.bodies[1].drive.force = Vec3(0.6, 0, 0);  // above friction (0.8 x 0.49 N): the ball slides
  for (int i = 0; i < 60; ++i) w.Step();
  ASSERT_GT(w.bodies[1].velocity.x(), 1e-3);
  int sides = 0;
  for (const ContactRow& r : w.rows) {
    if (r.side[1].count < 1) continue;
    ++sides;
    const double tol = w.params.reuse_anchor_tolerance * w.bodies[r.contact.body[1]].deform.spacing();
    EXPECT_LE((r.side[1].weights_at - r.contact.anchor[1]).norm(), tol);
  }
  EXPECT_GT(sides, 0);
  EXPECT_LT(w.profile.work.weights_reused, sides);
}

}  // namespace
}  // namespace gs
