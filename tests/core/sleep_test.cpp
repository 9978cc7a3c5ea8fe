// Bodies at rest skip collision detection (core/sleep.cpp, docs/skip.md): a
// resting box falls asleep and its pairs reuse the last contacts; a body dropped
// on it wakes it, and the run matches the same run without sleep; a body held
// by moving fingers never sleeps.
#include <gtest/gtest.h>

#include <cmath>

#include "core/world.h"
#include "soft_bodies.h"

namespace gs {
namespace {

using test::AddPlane;

BodySpec Box(const char* name, const Vec3& at, double half, bool deformable) {
  BodySpec b = test::SmallBox(name, at, half);
  if (deformable) {
    b.deformation.model = EDeformation::Gaussian;
    b.deformation.stiffness = 2000;
    b.deformation.damping = 5;
    b.deformation.influence_radius = 0.003;
  }
  return b;
}

void SetParams(World& w, bool sleep) {
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-7;
  w.params.solver.max_iterations = 200;
  w.params.sleep.enabled = sleep;
}

// a deformable box resting on the plane
World RestingBox(bool sleep) {
  World w;
  SetParams(w, sleep);
  AddPlane(w);
  AddBody(w, Box("low", Vec3(0, 0, 0.0101), 0.01, true));
  return w;
}

double PoseDistance(const Pose& a, const Pose& b) { return (a.t - b.t).norm() + (a.R - b.R).norm() * 0.01; }

TEST(Sleep, RestingBoxFallsAsleepAndSkipsItsPair) {
  World w = RestingBox(true), ref = RestingBox(false);
  w.Finalize();
  ref.Finalize();
  int first_asleep = -1;
  for (int i = 0; i < 400; ++i) {
    w.Step();
    ref.Step();
    if (first_asleep < 0 && w.bodies[1].asleep) first_asleep = i;
  }
  // settled (a few tenths of a second) and then asleep for good
  ASSERT_GE(first_asleep, 100);
  ASSERT_LT(first_asleep, 300);
  EXPECT_TRUE(w.bodies[1].asleep);
  const StepWork& k = w.profile.work;
  EXPECT_EQ(k.bodies_asleep, 1);
  EXPECT_EQ(k.body_pairs, 1);
  EXPECT_EQ(k.pairs_asleep, 1);
  EXPECT_EQ(k.pair_tests, 0);
  EXPECT_EQ(k.pairs_traversed, 0);
  EXPECT_EQ(w.profile.collision.projections, 0);
  EXPECT_GT(k.contacts_reused, 10);
  EXPECT_EQ(k.contacts_reused, w.profile.contacts);
  // without sleep the pair is detected every step, with as many contacts
  EXPECT_EQ(ref.profile.work.pairs_asleep, 0);
  EXPECT_EQ(ref.profile.work.pairs_traversed, 1);
  EXPECT_EQ(ref.profile.contacts, w.profile.contacts);
  // the same physics: the box rests where it rests without sleep, forces alike
  EXPECT_LT(PoseDistance(w.bodies[1].pose, ref.bodies[1].pose), 1e-9);
  double fw = 0, fr = 0;
  for (const ContactRow& r : w.rows) fw += r.r[0];
  for (const ContactRow& r : ref.rows) fr += r.r[0];
  EXPECT_NEAR(fw, fr, 1e-6 * std::abs(fr));
  EXPECT_NEAR(fw, w.bodies[1].mass * 9.81, 1e-3);
}

// a box held by a stiff drive above the resting one, released at step `release`
World Stack(bool sleep) {
  World w;
  SetParams(w, sleep);
  AddPlane(w);
  AddBody(w, Box("low", Vec3(0, 0, 0.0101), 0.01, true));
  BodySpec top = Box("top", Vec3(0.002, 0.001, 0.0331), 0.01, true);
  top.drive.enabled = true;
  top.drive.stiffness = Vec3::Constant(2e3);
  top.drive.damping = Vec3::Constant(20);
  top.drive.angular_stiffness = Vec3::Constant(2);
  top.drive.angular_damping = Vec3::Constant(0.02);
  top.drive.target = top.pose;
  top.drive.target.t.z() += 0.05 * 9.81 / 2e3;  // the spring carries the weight where the box starts
  AddBody(w, top);
  w.Finalize();
  return w;
}

TEST(Sleep, ReleasedBoxWakesTheStackAndMatchesTheRunWithoutSleep) {
  World w = Stack(true), ref = Stack(false);
  const int release = 400;
  double worst = 0.0;
  int woke_at = -1, asleep_again = -1, skipped_pairs = 0;
  for (int i = 0; i < 1200; ++i) {
    if (i == release) {
      ASSERT_TRUE(w.bodies[1].asleep);  // low, resting
      ASSERT_TRUE(w.bodies[2].asleep);  // top, held still: no contact, reaches low's sphere
      w.bodies[2].drive.enabled = false;
      ref.bodies[2].drive.enabled = false;
    }
    w.Step();
    ref.Step();
    ASSERT_FALSE(w.profile.rejected);
    skipped_pairs += w.profile.work.pairs_asleep;
    if (i >= release && woke_at < 0 && !w.bodies[1].asleep && !w.bodies[2].asleep) woke_at = i;
    if (woke_at >= 0 && asleep_again < 0 && w.bodies[1].asleep && w.bodies[2].asleep) asleep_again = i;
    for (int b = 1; b <= 2; ++b) worst = std::max(worst, PoseDistance(w.bodies[b].pose, ref.bodies[b].pose));
  }
  EXPECT_GT(skipped_pairs, 300);
  // the drive's change wakes top in the release step; top moves and reaches low: both wake at once
  EXPECT_EQ(woke_at, release);
  // the two land, settle and fall asleep again
  EXPECT_GT(asleep_again, release + 100);
  EXPECT_GT(w.profile.contacts, 20);
  EXPECT_EQ(w.profile.work.bodies_asleep, 2);
  // the top box came down onto the low one and rests on it
  EXPECT_LT(w.bodies[2].pose.t.z(), 0.0315);
  EXPECT_LT(worst, 1e-7) << "largest pose difference from the run without sleep (m)";
  RecordProperty("worst_pose_difference_m", std::to_string(worst));
}

TEST(Sleep, BodyReachingASleepingOneWakesIt) {
  // a frictionless puck slides along the plane into a sleeping box
  auto make = [](bool sleep) {
    World w;
    SetParams(w, sleep);
    const int plane = AddPlane(w);
    AddBody(w, Box("box", Vec3(0, 0, 0.0101), 0.01, true));
    BodySpec puck = Box("puck", Vec3(-0.12, 0, 0.0051), 0.005, false);
    puck.velocity = Vec3(0.25, 0, 0);
    const int p = AddBody(w, puck);
    w.SetFriction(plane, p, 0.0);
    w.Finalize();
    return w;
  };
  World w = make(true), ref = make(false);
  int woke_at = -1, first_touch = -1, asleep_steps = 0;
  double worst = 0.0;
  for (int i = 0; i < 600; ++i) {
    const bool was_asleep = w.bodies[1].asleep;
    w.Step();
    ref.Step();
    asleep_steps += w.bodies[1].asleep;
    if (was_asleep && !w.bodies[1].asleep && woke_at < 0) woke_at = i;
    bool touch = false;
    for (const ContactRow& r : ref.rows) touch |= (r.contact.body[0] == 2) != (r.contact.body[1] == 2) &&
                                                  (r.contact.body[0] == 1 || r.contact.body[1] == 1);
    if (touch && first_touch < 0) first_touch = i;
    for (int b = 1; b <= 2; ++b) worst = std::max(worst, PoseDistance(w.bodies[b].pose, ref.bodies[b].pose));
  }
  // the box slept while the puck was far, and woke before the puck touched it
  EXPECT_GT(asleep_steps, 100);
  ASSERT_GE(first_touch, 0);
  ASSERT_GE(woke_at, 0);
  EXPECT_LT(woke_at, first_touch);
  EXPECT_GT(w.bodies[1].pose.t.x(), 1e-4) << "the puck pushed the box";
  EXPECT_LT(worst, 1e-7);
  RecordProperty("worst_pose_difference_m", std::to_string(worst));
}

TEST(Sleep, TeleportedOrSwitchedOffWakes) {
  World w = RestingBox(true);
  w.Finalize();
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_TRUE(w.bodies[1].asleep);
  // moved by hand farther than max_drift: detected again in the next step
  w.bodies[1].pose.t.x() += 1e-3;
  w.bodies[1].pose_prev = w.bodies[1].pose;
  w.Step();
  EXPECT_FALSE(w.bodies[1].asleep);
  EXPECT_EQ(w.profile.work.pairs_asleep, 0);
  EXPECT_EQ(w.profile.work.pairs_traversed, 1);
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_TRUE(w.bodies[1].asleep);
  // gravity changed: wakes
  w.params.gravity = Vec3(0, 0, -5.0);
  w.Step();
  EXPECT_FALSE(w.bodies[1].asleep);
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_TRUE(w.bodies[1].asleep);
  // sleep switched off: wakes, never sleeps again
  w.params.sleep.enabled = false;
  for (int i = 0; i < 300; ++i) {
    w.Step();
    ASSERT_FALSE(w.bodies[1].asleep);
    ASSERT_EQ(w.profile.work.pairs_asleep, 0);
  }
  // WakeAll, Finalize
  w.params.sleep.enabled = true;
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_TRUE(w.bodies[1].asleep);
  w.WakeAll();
  EXPECT_FALSE(w.bodies[1].asleep);
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_TRUE(w.bodies[1].asleep);
  w.Finalize();
  EXPECT_FALSE(w.bodies[1].asleep);
}

}  // namespace
}  // namespace gs
