#include "core/finger.h"

#include <Eigen/Dense>
#include <algorithm>

namespace gs {
namespace {

Mat3 RotY(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }
Mat3 RotZ(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }

}  // namespace

FingerKinematics FingerForward(const FingerModel& f, const Pose& hand, const Vec4& q) {
  FingerKinematics k;
  const Pose base = hand * f.base;
  // abduction about the base z axis
  k.axis[0] = base.R.col(2);
  k.origin[0] = base.t;
  Pose frame{base.R * RotZ(q[0]), base.t};
  // three flexions about the current y axis, links along x
  for (int j = 1; j <= 3; ++j) {
    k.axis[j] = frame.R.col(1);
    k.origin[j] = frame.t;
    frame.R = frame.R * RotY(q[j]);
    k.link[j - 1] = frame;
    frame.t = frame.t + frame.R.col(0) * f.link_lengths[j - 1];
  }
  // fingertip: offset in the distal frame, shape z along the link x
  k.tip.t = frame.t + frame.R * f.tip_offset;
  k.tip.R = frame.R * RotY(M_PI / 2.0);
  return k;
}

Mat34 FingerPointJacobian(const FingerKinematics& k, const Vec3& p, int link) {
  Mat34 J = Mat34::Zero();
  for (int j = 0; j <= link && j < 4; ++j) J.col(j) = k.axis[j].cross(p - k.origin[j]);
  return J;
}

Mat34 FingerAngularJacobian(const FingerKinematics& k, int link) {
  Mat34 J = Mat34::Zero();
  for (int j = 0; j <= link && j < 4; ++j) J.col(j) = k.axis[j];
  return J;
}

Vec4 ClampJoints(const FingerModel& f, const Vec4& q) {
  Vec4 out;
  for (int j = 0; j < 4; ++j) out[j] = std::clamp(q[j], f.limits[j][0], f.limits[j][1]);
  return out;
}

double FingerInverse(const FingerModel& f, const Vec3& target, const Vec4& q0, Vec4* q) {
  Vec4 x = ClampJoints(f, q0);
  const Pose hand;  // targets are in the hand frame
  double err = 0.0;
  for (int it = 0; it < 200; ++it) {
    const FingerKinematics k = FingerForward(f, hand, x);
    const Vec3 e = target - k.tip.t;
    err = e.norm();
    if (err < 1e-7) break;
    const Mat34 J = FingerPointJacobian(k, k.tip.t);
    // damped least squares step, small damping for a well-behaved redundancy
    const double lambda = 1e-4;
    const Mat3 JJt = J * J.transpose() + lambda * Mat3::Identity();
    const Vec4 dq = J.transpose() * JJt.ldlt().solve(e);
    x = ClampJoints(f, x + dq);
  }
  *q = x;
  return err;
}

}  // namespace gs
