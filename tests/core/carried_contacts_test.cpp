// Carried contacts (WorldParams::carry_contacts_after_s): in a step short of time, a
// body pair that has hardly moved skips collision detection and carries the last
// step's contacts, moved with the bodies. The moved gaps must be the ones detection
// finds at the new poses (to the second order of the slide), at most two steps in a
// row may carry, nothing carries by default or after WakeAll, and a ball rolling
// down a slope must roll as it does with detection in every step (5/7 g sin a): once
// it rolls, its contacts move too far to be carried.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include "core/world.h"
#include "soft_bodies.h"

namespace gs {
namespace {

// any step's own time exceeds this: every step that may carry does
constexpr double kAlwaysShort = 1e-12;

// a rigid 2 cm cube tilted by 0.3 degrees, 50 um over a fixed slab's top, drifting
// off it without gravity (up 1 mm/s, along 2 mm/s, turning at 0.1 rad/s: about 3 um
// a step, under carry_max_slide_m): contacts within the threshold, no force
void BoxLeavingSlab(World& w) {
  w.params.gravity = Vec3::Zero();
  ASSERT_GE(AddBody(w, test::SoftSlab("slab")), 0);
  BodySpec box = test::SmallBox("box", Vec3(0, 0, 0.02005 + 0.01 * std::sin(0.3 * M_PI / 180)), 0.01);
  box.pose.R = Eigen::AngleAxisd(0.3 * M_PI / 180, Vec3::UnitX()).toRotationMatrix();
  const int b = AddBody(w, box);
  ASSERT_GE(b, 0);
  w.Finalize();
  w.bodies[b].velocity = Vec3(0.002, 0.0, 0.001);
  w.bodies[b].angular_velocity = Vec3(0.0, 0.1, 0.0);
}

TEST(CarriedContacts, MovedGapsAreTheGapsDetectionFinds) {
  World w;
  BoxLeavingSlab(w);
  w.params.carry_contacts_after_s = kAlwaysShort;
  w.Step();
  ASSERT_FALSE(w.profile.contacts_carried);  // the first step after Finalize detects
  std::map<uint64_t, double> first;
  for (const Contact& c : w.contacts.items) first[c.key] = c.gap;
  w.Step();
  ASSERT_TRUE(w.profile.contacts_carried);
  EXPECT_EQ(w.profile.work.contacts_carried, static_cast<int>(first.size()));
  for (const ContactRow& r : w.rows) EXPECT_EQ(r.r.norm(), 0.0);  // separating: no force moved anything
  const std::vector<Contact> carried = w.contacts.items;
  // detection at the same poses
  DetectCollisions(w);
  std::map<uint64_t, const Contact*> fresh;
  for (const Contact& c : w.contacts.items) fresh[c.key] = &c;
  int matched = 0;
  double worst_gap = 0.0, worst_turn = 0.0, moved = 0.0;
  for (const Contact& c : carried) {
    const auto f = fresh.find(c.key);
    if (f == fresh.end()) continue;
    ++matched;
    worst_gap = std::max(worst_gap, std::abs(c.gap - f->second->gap));
    worst_turn = std::max(worst_turn, (c.normal - f->second->normal).norm());
    moved += std::abs(c.gap - first[c.key]);
  }
  EXPECT_GE(matched, 10);
  // the gaps changed by about 1 um in the step (on average); moved, they are within 0.05 um of
  // detection's (the slide's second order, and the projections' own tolerance)
  EXPECT_GT(moved / matched, 5e-7);
  EXPECT_LT(worst_gap, 5e-8);
  EXPECT_LT(worst_turn, 1e-3);
}

TEST(CarriedContacts, AtMostTwoStepsInARowAndNoneByDefaultOrAfterWakeAll) {
  World w;
  BoxLeavingSlab(w);
  std::vector<bool> carried;
  for (int i = 0; i < 3; ++i) {
    w.Step();
    EXPECT_FALSE(w.profile.contacts_carried) << "no carrying by default";
  }
  w.params.carry_contacts_after_s = kAlwaysShort;
  for (int i = 0; i < 9; ++i) {
    w.Step();
    carried.push_back(w.profile.contacts_carried);
  }
  // a detecting step, then two carrying ones, over and over
  const std::vector<bool> expected = {true, true, false, true, true, false, true, true, false};
  EXPECT_EQ(carried, expected);
  EXPECT_EQ(w.carried_steps, 6);
  w.Step();  // carries (the last one detected)
  ASSERT_TRUE(w.profile.contacts_carried);
  w.WakeAll();
  w.Step();
  EXPECT_FALSE(w.profile.contacts_carried) << "a state changed by hand is detected";
  // a share no step exceeds: every step detects
  w.params.carry_contacts_after_s = 1.0;
  for (int i = 0; i < 4; ++i) {
    w.Step();
    EXPECT_FALSE(w.profile.contacts_carried);
  }
}

// a rigid 1 cm ball rolling down a plane tilted by 20 degrees at friction 0.5 for
// 0.4 s from rest; returns the distance rolled along the slope
double RollDown(double carry_after) {
  World w;
  w.params.default_friction = 0.5;
  w.params.carry_contacts_after_s = carry_after;
  const Pose slope = Pose::FromAxisAngle(Vec3::UnitY(), 20.0 * M_PI / 180.0);
  BodySpec plane;
  plane.name = "plane";
  plane.is_plane = true;
  plane.pose = slope;
  EXPECT_GE(AddBody(w, plane), 0);
  BodySpec ball = test::SoftBall(slope.Apply(Vec3(0, 0, 0.01)), false);
  const int b = AddBody(w, ball);
  EXPECT_GE(b, 0);
  w.Finalize();
  const Vec3 start = w.bodies[b].pose.t;
  for (int i = 0; i < 400; ++i) w.Step();
  EXPECT_EQ(w.rejected_steps, 0);
  if (carry_after > 0.0) {
    // while it starts (under 5 mm/s) its contacts are carried, then detected
    EXPECT_GT(w.carried_steps, 0);
    EXPECT_LT(w.carried_steps, 40);
  }
  return (w.bodies[b].pose.t - start).dot(slope.R.col(0));
}

TEST(CarriedContacts, ABallRollsDownASlopeAsWithDetectionInEveryStep) {
  const double detected = RollDown(0.0);
  const double carried = RollDown(kAlwaysShort);
  // rolling without slipping: a = 5/7 g sin a (a solid ball)
  const double expected = 0.5 * (5.0 / 7.0) * 9.81 * std::sin(20.0 * M_PI / 180.0) * 0.4 * 0.4;
  EXPECT_NEAR(detected, expected, 0.02 * expected);
  EXPECT_NEAR(carried, expected, 0.02 * expected);
  EXPECT_NEAR(carried, detected, 0.002 * detected);
}

}  // namespace
}  // namespace gs
