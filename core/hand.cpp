#include "core/hand.h"

#include <cmath>

namespace gs {
namespace {

Mat3 Ry(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }

bool IsRotation(const Mat3& R) {
  return R.allFinite() && (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-3 && R.determinant() > 0.0;
}

}  // namespace

FingerChain ChainFromTip(const TrackedFinger& f) {
  FingerChain c;
  c.joint[0] = f.tip.t;
  c.R[0] = f.tip.R;
  // each phalanx runs back from its distal joint along -x of its frame
  for (int k = 0; k < kPhalanges; ++k) {
    if (k > 0) c.R[k] = c.R[k - 1] * Ry(f.angle[k - 1]);
    c.joint[k + 1] = c.joint[k] - f.length[k] * c.R[k].col(0);
  }
  return c;
}

TrackedFinger FingerFromRoot(const Pose& inner, const double length[kPhalanges], const double angle[2],
                             double tip_radius) {
  TrackedFinger f;
  f.tip_radius = tip_radius;
  for (int k = 0; k < kPhalanges; ++k) f.length[k] = length[k];
  f.angle[0] = angle[0];
  f.angle[1] = angle[1];
  // forward from the root: inner, then middle = inner Ry(-a_mi), outer = middle Ry(-a_om)
  Mat3 R = inner.R;
  Vec3 p = inner.t + length[2] * R.col(0);
  R = R * Ry(-angle[1]);
  p += length[1] * R.col(0);
  R = R * Ry(-angle[0]);
  p += length[0] * R.col(0);
  f.tip = Pose{R, p};
  return f;
}

Pose PhalanxCapsulePose(const FingerChain& c, EPhalanx k) {
  const int i = static_cast<int>(k);
  // Ry(90 deg) takes the body's z (the capsule axis) onto the phalanx's x
  return Pose{c.R[i] * Ry(0.5 * M_PI), 0.5 * (c.joint[i] + c.joint[i + 1])};
}

const char* FingerProblem(const TrackedFinger& f, double min_length, double max_length) {
  if (!f.tip.t.allFinite() || !f.tip.R.allFinite()) return "the fingertip pose is not finite";
  if (!IsRotation(f.tip.R)) return "the outer phalanx's orientation is not a rotation";
  for (double l : f.length)
    if (!(l >= min_length && l <= max_length)) return "a phalanx length is out of range";
  if (!(f.tip_radius > 0.0 && f.tip_radius <= max_length)) return "the fingertip radius is out of range";
  for (double a : f.angle)
    if (!(std::abs(a) <= M_PI)) return "an angle between phalanges is beyond 180 degrees";
  return nullptr;
}

HandModel AverageAdultHand(int fingers, bool right) {
  HandModel m;
  m.fingers = fingers == 3 ? 3 : 5;
  m.right = right;
  m.palm_size = Vec3(0.09, 0.085, 0.025);
  m.palm = Pose::Translation(Vec3(0.0, 0.0, 0.0125));
  // outer, middle, inner lengths and tip radius (the protocol's example hands, in m)
  static const double kFinger[kHandMaxFingers][4] = {{0.0317, 0.0339, 0.0450, 0.0095},
                                                     {0.0223, 0.0265, 0.0432, 0.0080},
                                                     {0.0241, 0.0299, 0.0473, 0.0080},
                                                     {0.0233, 0.0272, 0.0442, 0.0075},
                                                     {0.0205, 0.0214, 0.0382, 0.0070}};
  // the knuckles (root joints) set back so that the middle joints line up across
  // the hand at x = 9.5 cm; a right hand's thumb lies toward -y
  static const double kRootY[kHandMaxFingers] = {-0.040, -0.027, -0.009, 0.009, 0.027};
  const double side = right ? 1.0 : -1.0;
  for (int f = 0; f < kHandMaxFingers; ++f) {
    HandFingerModel& fm = m.finger[f];
    for (int k = 0; k < kPhalanges; ++k) fm.length[k] = kFinger[f][k];
    fm.radius = kFinger[f][3];
    const double x = f == 0 ? -0.040 : 0.095 - fm.length[2];
    fm.root.t = Vec3(x, side * kRootY[f], f == 0 ? 0.015 : 0.0125);
    // the thumb points forward and across the palm
    fm.root.R = f == 0 ? Eigen::AngleAxisd(side * 31.0 * M_PI / 180.0, Vec3::UnitZ()).toRotationMatrix()
                       : Mat3::Identity();
  }
  return m;
}

TrackedFinger PoseFinger(const HandModel& m, int f, const Pose& hand, const Vec3& q) {
  const HandFingerModel& fm = m.finger[f];
  const Pose inner = hand * Pose{fm.root.R * Ry(-q.x()), fm.root.t};
  const double angle[2] = {q.z(), q.y()};
  return FingerFromRoot(inner, fm.length, angle, fm.radius);
}

}  // namespace gs
