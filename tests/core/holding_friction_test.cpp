// The least holding friction (core/holding_friction.h) against grasps solved by
// hand: two opposed pads, two pads at different heights (their torque must be
// taken by unequal friction), three pads around a ring; a pad no friction can
// balance.
#include "core/holding_friction.h"

#include <gtest/gtest.h>

#include <cmath>

namespace gs {
namespace {

constexpr double kMass = 0.15, kG = 9.81;

World HeldBox() {
  World w;
  w.params.gravity = Vec3(0, 0, -kG);
  Body box;
  box.name = "box";
  box.mass = kMass;
  box.pose.t = Vec3(0.1, -0.2, 0.3);  // anywhere: the torques are about its centre
  w.bodies.push_back(box);
  w.bodies.emplace_back().name = "pad";
  return w;
}

// a pad at `at` (relative to the box centre) pushing the box along `n` with N newtons,
// the row's body[0] the box (rows.reverse_sides: the box as body[1], the force reversed)
void AddPush(World& w, const Vec3& at, const Vec3& n, double N, bool box_second = false) {
  ContactRow& r = w.rows.emplace_back();
  const Vec3 normal = box_second ? Vec3(-n) : n;
  const Vec3 t1 = normal.unitOrthogonal(), t2 = normal.cross(t1);
  r.frame.row(0) = normal.transpose();
  r.frame.row(1) = t1.transpose();
  r.frame.row(2) = t2.transpose();
  r.contact.body[0] = box_second ? 1 : 0;
  r.contact.body[1] = box_second ? 0 : 1;
  r.world_point = w.bodies[0].pose.t + at;
  r.r = Vec3(N, 0.0, 0.0);
}

TEST(HoldingFriction, TwoOpposedPadsNeedHalfTheWeightOverTheSqueeze) {
  World w = HeldBox();
  const double N = 2.0;
  AddPush(w, Vec3(-0.03, 0, 0), Vec3::UnitX(), N);
  AddPush(w, Vec3(0.03, 0, 0), -Vec3::UnitX(), N, true);
  const HoldingFriction h = LeastHoldingFriction(w, 0);
  EXPECT_EQ(h.contacts, 2);
  EXPECT_NEAR(h.mu, kMass * kG / (2 * N), 1e-7);
  // the rows carry no friction: the box is not at rest under the step's own forces
  EXPECT_NEAR(h.net_force, kMass * kG, 1e-12);
  EXPECT_LT(h.unreached, 1e-12);  // the pads balance each other: the rest is friction's
}

TEST(HoldingFriction, PadsAtTwoHeightsTakeTheirCoupleByUnequalFriction) {
  // normal forces at heights z1 and z2 on faces 2a apart turn the box by N (z1 - z2);
  // the friction forces balance it: T2 - T1 = N (z1 - z2) / a, T1 + T2 = m g, so the
  // more loaded pad needs mu* = m g / (2 N) + |z1 - z2| / (2 a)
  World w = HeldBox();
  const double N = 2.5, a = 0.03, z1 = 0.004, z2 = -0.003;
  AddPush(w, Vec3(-a, 0, z1), Vec3::UnitX(), N);
  AddPush(w, Vec3(a, 0, z2), -Vec3::UnitX(), N);
  EXPECT_NEAR(LeastHoldingFriction(w, 0).mu, kMass * kG / (2 * N) + std::abs(z1 - z2) / (2 * a), 1e-7);
}

TEST(HoldingFriction, ThreePadsAroundARingShareTheWeight) {
  World w = HeldBox();
  const double N = 1.2;
  for (int i = 0; i < 3; ++i) {
    const double phi = 2.0 * M_PI * i / 3.0;
    const Vec3 out(std::cos(phi), std::sin(phi), 0.0);
    AddPush(w, 0.02 * out, -out, N);
  }
  EXPECT_NEAR(LeastHoldingFriction(w, 0).mu, kMass * kG / (3 * N), 1e-7);
}

TEST(HoldingFriction, OnePadCannotHoldTheBox) {
  World w = HeldBox();
  AddPush(w, Vec3(-0.03, 0, 0), Vec3::UnitX(), 2.0);
  const HoldingFriction h = LeastHoldingFriction(w, 0);
  EXPECT_TRUE(std::isinf(h.mu));
  // no friction force takes the pad's 2 N push (along its normal), whatever else is left
  EXPECT_GE(h.unreached, 2.0 - 1e-9);
  World none = HeldBox();
  EXPECT_TRUE(std::isinf(LeastHoldingFriction(none, 0).mu));
}

}  // namespace
}  // namespace gs
