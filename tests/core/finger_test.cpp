#include "core/finger.h"

#include <gtest/gtest.h>

namespace gs {
namespace {

FingerModel Index() {
  FingerModel f;
  f.base = Pose::FromAxisAngle(Vec3(0, 0, 1), 0.4, Vec3(0.01, 0.02, 0.03));
  f.link_lengths = {0.035, 0.025, 0.018};
  f.limits = {{{-0.6, 0.6}, {-0.2, 1.6}, {0.0, 1.8}, {0.0, 1.6}}};
  f.tip_offset = Vec3(0.0, 0.0, -0.004);
  return f;
}

TEST(Finger, ExtendedFingerPointsAlongBaseX) {
  FingerModel f = Index();
  f.base = Pose{};
  f.tip_offset.setZero();
  const FingerKinematics k = FingerForward(f, Pose{}, Vec4::Zero());
  EXPECT_NEAR((k.tip.t - Vec3(0.078, 0, 0)).norm(), 0.0, 1e-15);
  // the fingertip shape's z axis follows the distal link
  EXPECT_NEAR((k.tip.R.col(2) - Vec3::UnitX()).norm(), 0.0, 1e-12);
  // positive flexion curls toward -z
  const FingerKinematics bent = FingerForward(f, Pose{}, Vec4(0, 0.5, 0.5, 0.5));
  EXPECT_LT(bent.tip.t.z(), -0.02);
}

TEST(Finger, JacobianMatchesFiniteDifferences) {
  const FingerModel f = Index();
  const Pose hand = Pose::FromAxisAngle(Vec3(1, 2, 3), 0.7, Vec3(0.1, -0.2, 0.3));
  const Vec4 q(0.1, 0.4, 0.6, 0.3);
  const FingerKinematics k = FingerForward(f, hand, q);
  // a material point of the fingertip, off its centre
  const Vec3 local(0.002, -0.003, 0.005);
  const Vec3 p = k.tip.Apply(local);
  const Mat34 J = FingerPointJacobian(k, p);
  const double eps = 1e-7;
  for (int j = 0; j < 4; ++j) {
    Vec4 qp = q, qm = q;
    qp[j] += eps;
    qm[j] -= eps;
    const Vec3 fd = (FingerForward(f, hand, qp).tip.Apply(local) - FingerForward(f, hand, qm).tip.Apply(local)) / (2 * eps);
    EXPECT_NEAR((fd - J.col(j)).norm(), 0.0, 1e-7) << "joint " << j;
  }
}

TEST(Finger, LinkJacobiansMatchFiniteDifferencesAndIgnoreLaterJoints) {
  const FingerModel f = Index();
  const Pose hand = Pose::FromAxisAngle(Vec3(1, -2, 3), 0.5, Vec3(0.1, -0.2, 0.3));
  const Vec4 q(0.15, 0.4, 0.6, 0.3);
  const FingerKinematics k = FingerForward(f, hand, q);
  const Vec3 local(0.004, -0.003, 0.002);  // a material point of each link, off its axis
  const double eps = 1e-7;
  for (int link = 1; link <= 3; ++link) {
    const Mat34 J = FingerPointJacobian(k, k.link[link - 1].Apply(local), link);
    const Mat34 Ja = FingerAngularJacobian(k, link);
    for (int j = 0; j < 4; ++j) {
      Vec4 qp = q, qm = q;
      qp[j] += eps;
      qm[j] -= eps;
      const Pose a = FingerForward(f, hand, qp).link[link - 1], b = FingerForward(f, hand, qm).link[link - 1];
      const Vec3 fd = (a.Apply(local) - b.Apply(local)) / (2 * eps);
      const Eigen::AngleAxisd turn(a.R * b.R.transpose());
      const Vec3 fd_angular = turn.axis() * turn.angle() / (2 * eps);
      EXPECT_NEAR((fd - J.col(j)).norm(), 0.0, 1e-7) << "link " << link << " joint " << j;
      EXPECT_NEAR((fd_angular - Ja.col(j)).norm(), 0.0, 1e-6) << "link " << link << " joint " << j;
      // a joint past the link does not move it
      if (j > link) {
        EXPECT_EQ(J.col(j).norm() + Ja.col(j).norm(), 0.0);
      }
    }
  }
  // the links chain: link l + 1 starts where link l ends
  for (int l = 0; l < 2; ++l)
    EXPECT_NEAR((k.link[l].t + f.link_lengths[l] * k.link[l].R.col(0) - k.link[l + 1].t).norm(), 0.0, 1e-15);
}

TEST(Finger, InverseKinematicsReachesReachableTargetsWithinLimits) {
  const FingerModel f = Index();
  const Vec4 q_true(0.2, 0.5, 0.7, 0.4);
  const Vec3 target = FingerForward(f, Pose{}, q_true).tip.t;
  Vec4 q;
  const double err = FingerInverse(f, target, Vec4(0, 0.2, 0.2, 0.2), &q);
  EXPECT_LT(err, 1e-6);
  for (int j = 0; j < 4; ++j) {
    EXPECT_GE(q[j], f.limits[j][0]);
    EXPECT_LE(q[j], f.limits[j][1]);
  }
  // an unreachable target: the residual says so, the joints stay within limits
  const double far = FingerInverse(f, Vec3(1, 0, 0), Vec4::Zero(), &q);
  EXPECT_GT(far, 0.5);
  for (int j = 0; j < 4; ++j) EXPECT_TRUE(q[j] >= f.limits[j][0] && q[j] <= f.limits[j][1]);
}

}  // namespace
}  // namespace gs
