// Mailbox, mapping to fingertip targets, target follower and virtual coupling.
#include <gtest/gtest.h>

#include <atomic>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/virtual_coupling.h"
#include "tracking/hand_mapping.h"
#include "tracking/mailbox.h"
#include "tracking/synthetic_hand.h"
#include "tracking/target_follower.h"

namespace gs::tracking {
namespace {

std::string Packet(const std::string& name) {
  std::ifstream f(std::string(GRASPSIM_TEST_DATA) + "/dtrack/" + name, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

TEST(Mailbox, NewestValueOnceThenNothing) {
  LatestMailbox<int> box;
  int v = 0;
  EXPECT_FALSE(box.Read(&v));
  box.Write(1);
  ASSERT_TRUE(box.Read(&v));
  EXPECT_EQ(v, 1);
  EXPECT_FALSE(box.Read(&v));
  box.Write(2);
  box.Write(3);
  ASSERT_TRUE(box.Read(&v));
  EXPECT_EQ(v, 3);  // 2 was stale: dropped
  EXPECT_EQ(box.writes(), 3u);
}

// a writer and a reader thread: every value read is whole (never torn) and newer than the last
TEST(Mailbox, ConcurrentValuesAreWholeAndInOrder) {
  struct Big {
    uint64_t a = 0;
    double b[16] = {};
  };
  LatestMailbox<Big> box;
  constexpr uint64_t kCount = 200000;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    Big v;
    for (uint64_t i = 1; i <= kCount; ++i) {
      v.a = i;
      for (double& x : v.b) x = static_cast<double>(i);
      box.Write(v);
    }
    done = true;
  });
  uint64_t last = 0, reads = 0, torn = 0, backwards = 0;
  Big v;
  for (;;) {
    const bool finished = done.load();  // read before the mailbox: nothing can follow a final empty read
    if (!box.Read(&v)) {
      if (finished) break;
      continue;
    }
    ++reads;
    for (double x : v.b) torn += x != static_cast<double>(v.a);
    backwards += v.a <= last;
    last = v.a;
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_GT(reads, 0u);
  EXPECT_EQ(last, kCount);  // the newest value always arrives
}

TrackerConfig HandConfig() {
  TrackerConfig c;
  for (int i = 0; i < 3; ++i) {
    FingertipMap f;
    f.name = i == 0 ? "thumb" : (i == 1 ? "index" : "middle");
    f.finger = i;
    f.body_id = i;
    c.fingertips.push_back(f);
  }
  return c;
}

TEST(HandMapping, GlHandZUpMillimetresToMetres) {
  DTrackParser p;
  DTrackFrame f;
  ASSERT_EQ(p.Parse(Packet("c_right_hand_3.txt"), &f), 0);
  TrackerConfig c = HandConfig();
  TargetSample s;
  MapFrame(f, c, &s);
  ASSERT_EQ(s.count, 3);
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(s.valid[i]);
    EXPECT_LT((s.pose[i].t - 1e-3 * f.hands[0].fingers[i].room_position).norm(), 1e-12);
    EXPECT_LT((s.pose[i].R.transpose() * s.pose[i].R - Mat3::Identity()).norm(), 1e-12);
  }
  // Y up (Powerwall): the room's y becomes the world's z, the room's -z the world's y
  c.up = EUpAxis::Y;
  TargetSample y;
  MapFrame(f, c, &y);
  const Vec3 r = 1e-3 * f.hands[0].fingers[1].room_position;
  EXPECT_NEAR(y.pose[1].t.z(), r.y(), 1e-12);
  EXPECT_NEAR(y.pose[1].t.y(), -r.z(), 1e-12);
  EXPECT_NEAR(y.pose[1].t.x(), r.x(), 1e-12);
  // calibration (world from room) and a per-fingertip offset in the fingertip's frame
  c.up = EUpAxis::Z;
  c.calibration = Pose::FromAxisAngle(Vec3::UnitZ(), M_PI / 2, Vec3(1, 2, 3));
  c.fingertips[2].offset = Pose::Translation(Vec3(0.01, 0, 0));
  TargetSample k;
  MapFrame(f, c, &k);
  const Vec3 tip = 1e-3 * f.hands[0].fingers[2].room_position;
  const Mat3 Rtip = c.calibration.R * f.hands[0].fingers[2].room_rotation;
  EXPECT_LT((k.pose[2].t - (c.calibration.Apply(tip) + Rtip * Vec3(0.01, 0, 0))).norm(), 1e-6);
  // a hand ID that is not in the frame: every target lost
  c.hand_id = 1;
  MapFrame(f, c, &k);
  EXPECT_FALSE(k.valid[0] || k.valid[1] || k.valid[2]);
}

TEST(HandMapping, SixDBodiesByIdNotPosition) {
  DTrackParser p;
  DTrackFrame f;
  ASSERT_EQ(p.Parse(Packet("b_untracked.txt"), &f), 0);  // only body 2 is tracked
  TrackerConfig c = HandConfig();
  c.source = ESource::Bodies;
  TargetSample s;
  MapFrame(f, c, &s);
  EXPECT_FALSE(s.valid[0]);
  EXPECT_FALSE(s.valid[1]);
  ASSERT_TRUE(s.valid[2]);
  EXPECT_NEAR(s.pose[2].t.z(), 0.980771, 1e-12);
}

TEST(HandMapping, SyntheticHandTipsSurviveTheRoundTrip) {
  SyntheticHand hand;
  Vec3 tips[5];
  hand.Tips(1.2, tips);
  DTrackParser p;
  DTrackFrame f;
  ASSERT_EQ(p.Parse(hand.Datagram(1.2, 7), &f), 0) << p.last_error();
  TargetSample s;
  MapFrame(f, HandConfig(), &s);
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(s.valid[i]);
    EXPECT_LT((s.pose[i].t - 1e-3 * tips[i]).norm(), 2e-6) << i;  // %.3f mm and %.6f matrices
  }
  hand.fingers = 5;
  ASSERT_EQ(p.Parse(hand.Datagram(0.5, 8), &f), 0) << p.last_error();
  EXPECT_EQ(f.hands[0].num_fingers, 5);
}

World OneTipWorld() {
  World w;
  BodySpec spec;
  spec.name = "tip";
  spec.shape.type = EShape::Sphere;
  spec.shape.radius = 0.008;
  spec.geometry.points = 200;
  spec.geometry.control_points = 30;
  spec.mass = 0.02;
  spec.pose = Pose::Translation(Vec3(0, 0, 0.1));
  EXPECT_EQ(AddBody(w, spec), 0);
  w.Finalize();
  return w;
}

TrackerConfig OneTipConfig() {
  TrackerConfig c;
  FingertipMap f;
  f.name = "index";
  f.body = "tip";
  f.body_index = 0;
  c.fingertips.push_back(f);
  c.lost_timeout_s = 0.1;
  return c;
}

TargetSample OneTip(const Vec3& p, bool valid = true) {
  TargetSample s;
  s.count = 1;
  s.valid[0] = valid;
  s.pose[0] = Pose::Translation(p);
  return s;
}

TEST(TargetFollower, WaitsInterpolatesHoldsAndReleases) {
  World w = OneTipWorld();
  TargetFollower f;
  f.Init(OneTipConfig(), w);
  // no sample yet: the start pose holds (gravity compensated)
  f.Apply(w, 0.001);
  EXPECT_EQ(f.state(0), ETipState::Waiting);
  EXPECT_EQ(f.target(0).t, Vec3(0, 0, 0.1));
  for (int i = 0; i < 100; ++i) {
    f.Apply(w, w.time + w.params.dt);
    w.Step();
  }
  EXPECT_LT((w.bodies[0].pose.t - Vec3(0, 0, 0.1)).norm(), 1e-6);
  // the first sample applies at once; the next is reached over the sample interval
  f.Push(OneTip(Vec3(0, 0, 0.1)), 0.1);
  f.Push(OneTip(Vec3(0.01, 0, 0.1)), 0.11);
  f.Apply(w, 0.115);
  EXPECT_NEAR(f.target(0).t.x(), 0.005, 1e-12);
  f.Apply(w, 0.12);
  EXPECT_NEAR(f.target(0).t.x(), 0.01, 1e-12);
  f.Push(OneTip(Vec3(0.01, 0, 0.1)), 0.2);
  f.Apply(w, 0.2);
  EXPECT_EQ(f.state(0), ETipState::Tracking);
  // lost: the last target holds, then the coupling goes limp after the timeout
  f.Push(OneTip(Vec3(0.5, 0, 0), false), 0.21);
  f.Apply(w, 0.25);
  EXPECT_EQ(f.state(0), ETipState::Lost);
  EXPECT_NEAR(f.target(0).t.x(), 0.01, 1e-12);
  EXPECT_GT(w.bodies[0].drive.stiffness.x(), 0.0);
  f.Apply(w, 0.2 + 0.101);
  EXPECT_EQ(f.state(0), ETipState::Released);
  EXPECT_EQ(w.bodies[0].drive.stiffness.x(), 0.0);
  // found again: tracking resumes
  f.Push(OneTip(Vec3(0.02, 0, 0.1)), 0.4);
  f.Apply(w, 0.45);
  EXPECT_EQ(f.state(0), ETipState::Tracking);
}

// Samples of a target moving at 0.1 m/s, every 10 steps, pushed at the start of the
// step they arrive in and applied at its end (as TrackedSim does): every step's
// target velocity, the damping's feed-forward, is the motion's, including the step
// that ends as a blend reaches its sample (it read zero, and one step in ten the
// couplings lost their pull: a lifted box jerked at the tracker's rate). A sample
// that comes late leaves the target still, at zero velocity, until it arrives.
TEST(TargetFollower, SteadySamplesGiveEveryStepTheirVelocity) {
  World w = OneTipWorld();
  TargetFollower f;
  f.Init(OneTipConfig(), w);
  const double dt = w.params.dt;
  const Vec3 v(0.1, 0, 0);
  int checked = 0;
  for (int k = 0; k < 100; ++k) {
    const double t = k * dt;
    if (k % 10 == 0) f.Push(OneTip(Vec3(0, 0, 0.1) + v * t), t);
    f.Apply(w, t + dt);
    if (k < 10) continue;  // the first sample applies at once; the blends start with the second
    EXPECT_LT((f.velocity(0) - v).norm(), 1e-9 * v.norm()) << "step " << k;
    EXPECT_NEAR(f.target(0).t.x(), v.x() * (t + dt - 0.01), 1e-12) << "step " << k;
    ++checked;
  }
  EXPECT_EQ(checked, 90);
  EXPECT_EQ(f.angular_velocity(0), Vec3::Zero());  // it does not turn
  // the next sample 3 steps late: the target stops at the last one for those steps
  for (int k = 100; k < 103; ++k) {
    f.Apply(w, (k + 1) * dt);
    EXPECT_EQ(f.velocity(0), Vec3::Zero()) << "step " << k;
    EXPECT_NEAR(f.target(0).t.x(), v.x() * 0.09, 1e-12);
  }
}

// samples of a target turning at 1 rad/s about x: every step's angular velocity is the turn's
TEST(TargetFollower, TurningSamplesGiveEveryStepTheirAngularVelocity) {
  World w = OneTipWorld();
  TargetFollower f;
  f.Init(OneTipConfig(), w);
  const double dt = w.params.dt;
  for (int k = 0; k < 60; ++k) {
    const double t = k * dt;
    if (k % 10 == 0) f.Push([&] {
        TargetSample s = OneTip(Vec3(0, 0, 0.1));
        s.pose[0].R = Eigen::AngleAxisd(1.0 * t, Vec3::UnitX()).toRotationMatrix();
        return s;
      }(), t);
    f.Apply(w, t + dt);
    if (k >= 10) {
      EXPECT_LT((f.angular_velocity(0) - Vec3(1.0, 0, 0)).norm(), 1e-9) << "step " << k;
    }
  }
}

TEST(TargetFollower, NoDatagramsAtAllReleasesAfterTheTimeout) {
  World w = OneTipWorld();
  TargetFollower f;
  f.Init(OneTipConfig(), w);
  f.Push(OneTip(Vec3(0, 0, 0.1)), 0.0);
  f.Apply(w, 0.05);
  EXPECT_EQ(f.state(0), ETipState::Tracking);
  f.Apply(w, 0.2);
  EXPECT_EQ(f.state(0), ETipState::Released);
}

// a tracker jump of a metre: the spring force stays within its bound and the
// fingertip's speed grows no faster than max_force / mass allows
TEST(VirtualCoupling, TrackerJumpInjectsBoundedEnergy) {
  World w = OneTipWorld();
  CouplingParams p;
  p.max_force = 5.0;
  Body& b = w.bodies[0];
  const Pose far = Pose::FromAxisAngle(Vec3::UnitX(), 3.0, Vec3(1.0, 0, 0.1));
  double max_speed = 0.0;
  for (int i = 0; i < 50; ++i) {
    SetCouplingTarget(b, w.params.gravity, p, far, Vec3::Zero(), Vec3::Zero());
    EXPECT_LE(CouplingSpringForce(b).norm(), p.max_force + 1e-9);
    const Eigen::AngleAxisd rel(b.drive.target.R * b.pose.R.transpose());
    EXPECT_LE(rel.angle() * p.angular_stiffness, p.max_torque + 1e-9);
    w.Step();
    ASSERT_TRUE(b.pose.t.allFinite());
    max_speed = std::max(max_speed, b.velocity.norm());
  }
  EXPECT_LE(max_speed, p.max_force / b.mass * 50 * w.params.dt + 1e-9);
  EXPECT_GT(b.pose.t.x(), 0.01);  // and it does move toward the target
  // an unreachable target velocity is bounded too
  SetCouplingTarget(b, w.params.gravity, p, far, Vec3(1e6, 0, 0), Vec3(0, 0, 1e6));
  EXPECT_LE((b.drive.target.R * b.drive.force + b.mass * w.params.gravity).norm(), p.max_force + 1e-9);
}

TEST(VirtualCoupling, FollowsAMovingTargetWithoutLag) {
  World w = OneTipWorld();
  CouplingParams p;
  Body& b = w.bodies[0];
  const Vec3 v(0.1, 0, 0);  // 10 cm/s
  for (int i = 0; i < 500; ++i) {
    const double t = w.time + w.params.dt;
    SetCouplingTarget(b, w.params.gravity, p, Pose::Translation(Vec3(0, 0, 0.1) + v * t), v, Vec3::Zero());
    w.Step();
  }
  // with the feed-forward, steady-state error well under the v D / K = 1 mm of a plain spring-damper
  EXPECT_LT(std::abs(b.pose.t.x() - v.x() * w.time), 2e-4);
  EXPECT_NEAR(b.pose.t.z(), 0.1, 1e-4);  // weight compensated
}

// A target turning steadily at 2 rad/s about z: with the angular feed-forward the
// body turns with it; a plain angular spring-damper lags by w D_a / K_a = 0.02 rad
// (the couplings' 2e-4 N m s/rad over 0.02 N m/rad).
TEST(VirtualCoupling, FollowsATurningTargetWithoutLag) {
  for (const bool feed_forward : {true, false}) {
    World w = OneTipWorld();
    CouplingParams p;
    Body& b = w.bodies[0];
    const Vec3 omega(0, 0, 2.0);
    for (int i = 0; i < 500; ++i) {
      const double t = w.time + w.params.dt;
      const Pose target = Pose::FromAxisAngle(Vec3::UnitZ(), omega.z() * t, Vec3(0, 0, 0.1));
      SetCouplingTarget(b, w.params.gravity, p, target, Vec3::Zero(), feed_forward ? omega : Vec3::Zero());
      w.Step();
    }
    const Eigen::AngleAxisd lag(Eigen::AngleAxisd(omega.z() * w.time, Vec3::UnitZ()).toRotationMatrix() *
                                b.pose.R.transpose());
    if (feed_forward)
      EXPECT_LT(lag.angle(), 2e-3);
    else
      EXPECT_NEAR(lag.angle(), omega.z() * p.angular_damping / p.angular_stiffness, 4e-3);
  }
}

}  // namespace
}  // namespace gs::tracking
