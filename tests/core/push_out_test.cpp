// Guards found by `graspsim stress`: an overlap present at the start of a step is
// pushed out at a bounded speed, and a non-finite coupling target is ignored.
#include <gtest/gtest.h>

#include "core/virtual_coupling.h"
#include "core/world.h"

namespace gs {
namespace {

// a plane (body 0) and one rigid body (body 1) whose centre starts at height z
void OnPlane(World& w, BodySpec b, int points, int control_points, double mass, double z) {
  BodySpec plane;
  plane.name = "plane";
  plane.is_plane = true;
  AddBody(w, plane);
  b.geometry.points = points;
  b.geometry.control_points = control_points;
  b.mass = mass;
  b.pose = Pose::Translation(Vec3(0, 0, z));
  ASSERT_EQ(AddBody(w, b), 1);
  w.Finalize();
}

// a rigid ball of radius 1 cm whose centre starts `depth` below touching a plane
void BallInPlane(World& w, double depth) {
  BodySpec b;
  b.name = "ball";
  b.shape.type = EShape::Sphere;
  b.shape.radius = 0.01;
  OnPlane(w, b, 800, 120, 0.05, 0.01 - depth);
}

TEST(PushOut, DeepStartingOverlapLeavesAtTheBoundedSpeed) {
  World w;
  w.params.max_push_out_speed = 0.1;
  BallInPlane(w, 0.004);
  double rate_max = 0.0, v_max = 0.0, z_max = 0.0;
  for (int i = 0; i < 200; ++i) {
    const double z = w.bodies[1].pose.t.z();
    w.Step();
    rate_max = std::max(rate_max, (w.bodies[1].pose.t.z() - z) / w.params.dt);
    v_max = std::max(v_max, w.bodies[1].velocity.norm());
    z_max = std::max(z_max, w.bodies[1].pose.t.z());
  }
  EXPECT_LE(rate_max, 0.1 + 9.81 * w.params.dt);  // moved out no faster than the bound
  EXPECT_GT(rate_max, 0.05);                      // it does move out
  // the push-out leaves the ball no speed: it does not fly off the plane after it
  EXPECT_LT(v_max, 0.01);
  EXPECT_LT(z_max - w.bodies[1].pose.t.z(), 1e-5);  // it rocks on its control points, no more
  EXPECT_NEAR(w.bodies[1].pose.t.z(), 0.01, 5e-4);
  EXPECT_LT(w.bodies[1].velocity.norm(), 0.01);
}

TEST(PushOut, WithTheSpeedKeptTheBallFliesOffAfterThePushOut) {
  World w;
  w.params.max_push_out_speed = 0.1;
  w.params.push_out_keeps_no_speed = false;  // the push-out's speed stays with the ball
  BallInPlane(w, 0.004);
  double v_max = 0.0, z_max = 0.0;
  for (int i = 0; i < 200; ++i) {
    w.Step();
    v_max = std::max(v_max, w.bodies[1].velocity.norm());
    z_max = std::max(z_max, w.bodies[1].pose.t.z());
  }
  EXPECT_GT(v_max, 0.05);
  // 0.1 m/s against gravity: 0.5 mm up, then back to rest
  EXPECT_GT(z_max - w.bodies[1].pose.t.z(), 3e-4);
}

TEST(PushOut, UnboundedSpeedRemovesTheOverlapInOneStep) {
  World w;
  w.params.max_push_out_speed = 0.0;  // off: all at once
  w.params.push_out_keeps_no_speed = false;
  BallInPlane(w, 0.004);
  w.Step();
  EXPECT_GT(w.bodies[1].velocity.z(), 2.0);  // launched at ~4 m/s
}

TEST(PushOut, UnboundedPushOutWithoutItsSpeedLeavesTheBallAtRest) {
  World w;
  w.params.max_push_out_speed = 0.0;
  BallInPlane(w, 0.004);
  w.Step();
  const double out = w.bodies[1].pose.t.z();
  EXPECT_GT(out, 0.01 - 4e-4);  // out in one step (4 mm; the sampled ball rests a little low)
  EXPECT_TRUE(w.profile.push_out_split);
  EXPECT_LT(w.bodies[1].velocity.norm(), 0.02);  // one step of gravity, no launch
  for (int i = 0; i < 100; ++i) w.Step();
  EXPECT_NEAR(w.bodies[1].pose.t.z(), out, 2e-5);  // where the push left it: at rest
}

// A box placed on a table at its half height stands inside its own MLS surface, which
// rounds its edges a little outward (0.1 mm at 6,000 points on 5 cm): the push-out lifts
// it to where it rests, and it stays there instead of jumping.
TEST(PushOut, ABoxPlacedTouchingATableDoesNotJump) {
  for (const bool split : {true, false}) {
    World w;
    w.params.push_out_keeps_no_speed = split;
    BodySpec b;
    b.name = "box";
    b.shape.type = EShape::Box;
    b.shape.half_extents = Vec3::Constant(0.025);
    OnPlane(w, b, 6000, 800, 1.0, 0.025);
    ASSERT_EQ(w.bodies.size(), 2u);
    double z_max = 0.0;
    for (int i = 0; i < 300; ++i) {
      w.Step();
      z_max = std::max(z_max, w.bodies[1].pose.t.z());
    }
    const double rest = w.bodies[1].pose.t.z();
    EXPECT_GT(rest, 0.025) << "the box's MLS surface stands out of the box at its edges";
    if (split) {
      EXPECT_LT(z_max - rest, 2e-6);  // no jump
    } else {
      EXPECT_GT(z_max - rest, 1e-4);  // jumped up after the push-out
    }
  }
}

// Only the overlap a body starts the scene with is pushed out without speed: a body
// pushed into another later (here by hand; live, a tracker's teleport) is pushed out by
// the step's solve with the push's speed, as overlaps of sliding contacts are
TEST(PushOut, AnOverlapMadeAfterTheStartKeepsThePushOutsSpeed) {
  World w;
  w.params.max_push_out_speed = 0.1;
  BallInPlane(w, -0.0001);  // 0.1 mm above: no placement overlap
  for (int i = 0; i < 300; ++i) w.Step();
  EXPECT_EQ(w.bodies[1].placement_steps, 0);
  const double rest = w.bodies[1].pose.t.z();
  w.bodies[1].pose.t.z() -= 0.002;
  w.bodies[1].pose_prev = w.bodies[1].pose;
  w.WakeAll();
  double z_max = 0.0;
  bool split = false;
  for (int i = 0; i < 200; ++i) {
    w.Step();
    split |= w.profile.push_out_split;
    z_max = std::max(z_max, w.bodies[1].pose.t.z());
  }
  EXPECT_FALSE(split);
  EXPECT_GT(z_max - rest, 3e-4);  // thrown up by the push's 0.1 m/s
}

TEST(PushOut, RestingContactHoldsNothingBack) {
  World w;
  BallInPlane(w, -0.0001);
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_GT(w.rows.size(), 0u);
  for (const ContactRow& r : w.rows) EXPECT_EQ(r.held_back, 0.0);
}

TEST(VirtualCoupling, NonFiniteTargetIsIgnored) {
  Body b;
  b.mass = 0.01;
  b.pose = Pose::Translation(Vec3(0, 0, 0.05));
  CouplingParams p;
  const Pose good = Pose::Translation(Vec3(0.01, 0, 0.05));
  SetCouplingTarget(b, Vec3(0, 0, -9.81), p, good, Vec3::Zero(), Vec3::Zero());
  const Drive before = b.drive;
  Pose bad = good;
  bad.t.x() = NAN;
  SetCouplingTarget(b, Vec3(0, 0, -9.81), p, bad, Vec3::Zero(), Vec3::Zero());
  EXPECT_TRUE(b.drive.target.t.allFinite());
  EXPECT_EQ((b.drive.target.t - before.target.t).norm(), 0.0);
  bad = good;
  bad.R(1, 1) = INFINITY;
  SetCouplingTarget(b, Vec3(0, 0, -9.81), p, bad, Vec3::Zero(), Vec3::Zero());
  SetCouplingTarget(b, Vec3(0, 0, -9.81), p, good, Vec3(NAN, 0, 0), Vec3::Zero());
  SetCouplingTarget(b, Vec3(0, 0, -9.81), p, good, Vec3::Zero(), Vec3(0, NAN, 0));
  EXPECT_TRUE(b.drive.target.R.allFinite());
  EXPECT_TRUE(b.drive.force.allFinite());
  EXPECT_TRUE(b.drive.torque.allFinite());
}

}  // namespace
}  // namespace gs
