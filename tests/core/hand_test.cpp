#include "core/hand.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace gs {
namespace {

TrackedFinger Finger(const Pose& tip, double om, double mi) {
  TrackedFinger f;
  f.tip = tip;
  f.tip_radius = 0.008;
  f.length[0] = 0.02;  // outer
  f.length[1] = 0.03;  // middle
  f.length[2] = 0.04;  // inner
  f.angle[0] = om;
  f.angle[1] = mi;
  return f;
}

void ExpectNear(const Vec3& a, const Vec3& b, double tol) { EXPECT_LT((a - b).norm(), tol) << a.transpose() << " vs " << b.transpose(); }

TEST(Hand, StraightFingerRunsBackAlongTheTipsX) {
  const FingerChain c = ChainFromTip(Finger(Pose::Translation(Vec3(0.1, 0.0, 0.0)), 0.0, 0.0));
  ExpectNear(c.joint[0], Vec3(0.10, 0, 0), 1e-15);
  ExpectNear(c.joint[1], Vec3(0.08, 0, 0), 1e-15);
  ExpectNear(c.joint[2], Vec3(0.05, 0, 0), 1e-15);
  ExpectNear(c.joint[3], Vec3(0.01, 0, 0), 1e-15);
  for (const Mat3& R : c.R) EXPECT_LT((R - Mat3::Identity()).norm(), 1e-15);
}

TEST(Hand, FingerBentNinetyDegreesAtTheOuterJoint) {
  // outer phalanx along +x, a 90 degree flexion between it and the middle one: the
  // middle phalanx stands on the pad side (+z) of the outer joint, the inner continues it
  const FingerChain c = ChainFromTip(Finger(Pose{}, 0.5 * M_PI, 0.0));
  ExpectNear(c.joint[1], Vec3(-0.02, 0, 0), 1e-15);
  ExpectNear(c.joint[2], Vec3(-0.02, 0, 0.03), 1e-12);
  ExpectNear(c.joint[3], Vec3(-0.02, 0, 0.07), 1e-12);
  // the middle phalanx's x points from its root joint toward the tip: -z
  ExpectNear(c.R[1].col(0), Vec3(0, 0, -1), 1e-12);
  ExpectNear(c.R[2].col(0), Vec3(0, 0, -1), 1e-12);
}

TEST(Hand, FingerBentNinetyDegreesAtTheMiddleJointInATurnedHand) {
  // the tip frame turned 90 degrees about z: the chain turns with it
  const Pose tip = Pose::FromAxisAngle(Vec3::UnitZ(), 0.5 * M_PI, Vec3(0.01, 0.02, 0.03));
  const FingerChain c = ChainFromTip(Finger(tip, 0.0, 0.5 * M_PI));
  // x of the tip frame is world +y: the outer and middle phalanges run back along -y
  ExpectNear(c.joint[1], Vec3(0.01, 0.00, 0.03), 1e-12);
  ExpectNear(c.joint[2], Vec3(0.01, -0.03, 0.03), 1e-12);
  // then a right angle toward the pad (+z of the frames): the inner phalanx stands on +z
  ExpectNear(c.joint[3], Vec3(0.01, -0.03, 0.07), 1e-12);
}

TEST(Hand, FromRootAndFromTipAreInverses) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Pose inner = Pose::FromAxisAngle(Vec3(u(rng), u(rng), u(rng)), 3.0 * u(rng), Vec3(u(rng), u(rng), u(rng)));
    const double length[3] = {0.02 + 0.01 * u(rng), 0.03 + 0.01 * u(rng), 0.045 + 0.01 * u(rng)};
    const double angle[2] = {1.5 * u(rng), 1.5 * u(rng)};
    const TrackedFinger f = FingerFromRoot(inner, length, angle, 0.008);
    const FingerChain c = ChainFromTip(f);
    ExpectNear(c.joint[3], inner.t, 1e-12);
    EXPECT_LT((c.R[2] - inner.R).norm(), 1e-12);
    // each phalanx is as long as given, and the tip is where the tracker said
    for (int k = 0; k < 3; ++k) EXPECT_NEAR((c.joint[k] - c.joint[k + 1]).norm(), length[k], 1e-12);
    EXPECT_EQ(c.joint[0], f.tip.t);
  }
}

TEST(Hand, CapsulePoseSpansThePhalanx) {
  const FingerChain c = ChainFromTip(Finger(Pose::FromAxisAngle(Vec3(1, 2, 3), 0.7, Vec3(0.1, 0.2, 0.3)), 0.4, 0.9));
  for (int k = 0; k < 3; ++k) {
    const Pose p = PhalanxCapsulePose(c, static_cast<EPhalanx>(k));
    const double half = 0.5 * (c.joint[k] - c.joint[k + 1]).norm();
    // the capsule's axis (body z) runs from the proximal joint to the distal one
    ExpectNear(p.Apply(Vec3(0, 0, half)), c.joint[k], 1e-12);
    ExpectNear(p.Apply(Vec3(0, 0, -half)), c.joint[k + 1], 1e-12);
    EXPECT_NEAR(p.R.determinant(), 1.0, 1e-12);
  }
}

TEST(Hand, AverageHandHasAlignedMiddleJointsAndAThumbTowardMinusY) {
  const HandModel right = AverageAdultHand(5, true), left = AverageAdultHand(5, false);
  for (int f = 1; f < 5; ++f) {
    const FingerChain c = ChainFromTip(PoseFinger(right, f, Pose{}, Vec3::Zero()));
    EXPECT_NEAR(c.joint[2].x(), 0.095, 1e-12) << "finger " << f;
    // straight fingers lie along the hand's x
    EXPECT_NEAR(c.joint[0].z(), right.finger[f].root.t.z(), 1e-12);
  }
  const FingerChain thumb_r = ChainFromTip(PoseFinger(right, 0, Pose{}, Vec3::Zero()));
  const FingerChain thumb_l = ChainFromTip(PoseFinger(left, 0, Pose{}, Vec3::Zero()));
  EXPECT_LT(thumb_r.joint[3].y(), 0.0);
  EXPECT_GT(thumb_l.joint[3].y(), 0.0);
  ExpectNear(thumb_l.joint[0], Vec3(thumb_r.joint[0].x(), -thumb_r.joint[0].y(), thumb_r.joint[0].z()), 1e-12);
  // a flexion curls toward the palm side (+z of the hand frame)
  const FingerChain bent = ChainFromTip(PoseFinger(right, 1, Pose{}, Vec3(0.3, 0.6, 0.4)));
  EXPECT_GT(bent.joint[0].z(), right.finger[1].root.t.z() + 0.02);
}

TEST(Hand, PoseFingerFollowsTheHandPose) {
  const HandModel m = AverageAdultHand(5, true);
  const Pose hand = Pose::FromAxisAngle(Vec3(0.3, -1, 0.2), 1.1, Vec3(0.5, -0.2, 0.9));
  const Vec3 q(0.2, 0.7, 0.3);
  const TrackedFinger local = PoseFinger(m, 2, Pose{}, q), world = PoseFinger(m, 2, hand, q);
  ExpectNear(world.tip.t, hand.Apply(local.tip.t), 1e-12);
  EXPECT_LT((world.tip.R - hand.R * local.tip.R).norm(), 1e-12);
  EXPECT_EQ(world.angle[0], q.z());
  EXPECT_EQ(world.angle[1], q.y());
}

TEST(Hand, FingerProblemRefusesWhatCannotBeAHand) {
  const TrackedFinger good = Finger(Pose{}, 0.3, 0.4);
  EXPECT_EQ(FingerProblem(good, 0.005, 0.1), nullptr);
  TrackedFinger f = good;
  f.length[1] = 0.0;
  EXPECT_NE(FingerProblem(f, 0.005, 0.1), nullptr);
  f = good;
  f.length[2] = 1.0;
  EXPECT_NE(FingerProblem(f, 0.005, 0.1), nullptr);
  f = good;
  f.tip.t.x() = std::nan("");
  EXPECT_NE(FingerProblem(f, 0.005, 0.1), nullptr);
  f = good;
  f.tip.R = Mat3::Zero();
  EXPECT_NE(FingerProblem(f, 0.005, 0.1), nullptr);
  f = good;
  f.tip.R(0, 0) = -1.0;  // a reflection
  EXPECT_NE(FingerProblem(f, 0.005, 0.1), nullptr);
  f = good;
  f.angle[0] = std::nan("");
  EXPECT_NE(FingerProblem(f, 0.005, 0.1), nullptr);
  f = good;
  f.tip_radius = 0.0;
  EXPECT_NE(FingerProblem(f, 0.005, 0.1), nullptr);
}

}  // namespace
}  // namespace gs
