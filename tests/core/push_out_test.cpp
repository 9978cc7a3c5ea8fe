// Guards found by `graspsim stress`: an overlap present at the start of a step is
// pushed out at a bounded speed, and a non-finite coupling target is ignored.
#include <gtest/gtest.h>

#include "core/virtual_coupling.h"
#include "core/world.h"

namespace gs {
namespace {

// a rigid ball of radius 1 cm whose centre starts `depth` below touching a plane
void BallInPlane(World& w, double depth) {
  BodySpec plane;
  plane.name = "plane";
  plane.is_plane = true;
  AddBody(w, plane);
  BodySpec b;
  b.name = "ball";
  b.shape.type = EShape::Sphere;
  b.shape.radius = 0.01;
  b.geometry.points = 800;
  b.geometry.control_points = 120;
  b.mass = 0.05;
  b.pose = Pose::Translation(Vec3(0, 0, 0.01 - depth));
  ASSERT_EQ(AddBody(w, b), 1);
  w.Finalize();
}

TEST(PushOut, DeepStartingOverlapLeavesAtTheBoundedSpeed) {
  World w;
  w.params.max_push_out_speed = 0.1;
  BallInPlane(w, 0.004);
  double vmax = 0.0;
  for (int i = 0; i < 200; ++i) {
    w.Step();
    vmax = std::max(vmax, w.bodies[1].velocity.norm());
  }
  EXPECT_LE(vmax, 0.1 + 9.81 * w.params.dt);  // plus one step of gravity
  EXPECT_GT(vmax, 0.05);  // it does move out
  // out after 40 ms at 0.1 m/s, and resting on the plane
  EXPECT_NEAR(w.bodies[1].pose.t.z(), 0.01, 5e-4);
  EXPECT_LT(w.bodies[1].velocity.norm(), 0.02);
}

TEST(PushOut, UnboundedSpeedRemovesTheOverlapInOneStep) {
  World w;
  w.params.max_push_out_speed = 0.0;  // off: the old behaviour
  BallInPlane(w, 0.004);
  w.Step();
  EXPECT_GT(w.bodies[1].velocity.z(), 2.0);  // launched at ~4 m/s
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
