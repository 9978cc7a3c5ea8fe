// A finger: a serial chain of four revolute joints (abduction, then three
// flexions) carrying a fingertip body, driven by generalized motor torques
// toward joint targets (the paper's position-controlled fingers, section 4).
//
// Kinematic convention (all frames right-handed):
// - the finger's base frame is fixed in the hand frame; its x axis points along
//   the extended finger, z is the abduction axis, y the flexion axis;
// - joint 0 rotates about the base z axis (abduction); joints 1..3 rotate about
//   the current y axis (flexion); a positive flexion curls the finger toward the
//   base frame's -z side (the palm side), since Ry(+a) turns +x toward -z;
// - joint 1 sits at the base origin, joint 2 at L1 along the first link's x,
//   joint 3 at L2 further; the distal link ends at L3;
// - the fingertip body's frame is the distal link frame translated by `tip_offset`
//   and turned so that the fingertip shape's z axis lies along the link's x axis
//   (a fingertip ellipsoid's long axis follows the finger).
#pragma once

#include <array>

#include "core/types.h"

namespace gs {

using Vec4 = Eigen::Matrix<double, 4, 1>;
using Mat34 = Eigen::Matrix<double, 3, 4>;
using Mat4 = Eigen::Matrix<double, 4, 4>;

struct FingerModel {
  Pose base;                              ///< base frame in the hand frame
  std::array<double, 3> link_lengths{};   ///< L1, L2, L3 (m)
  std::array<std::array<double, 2>, 4> limits{};  ///< joint limits (rad)
  Vec3 tip_offset = Vec3::Zero();         ///< fingertip centre in the distal link frame (m)
};

/// Joint axes and origins in the world for one configuration.
struct FingerKinematics {
  std::array<Vec3, 4> axis;    ///< unit joint axes (world)
  std::array<Vec3, 4> origin;  ///< points on the joint axes (world, m)
  /// link frames (world): link l + 1 (l = 0, 1, 2: proximal to distal) after its
  /// flexion, origin at its proximal joint, x along the link; joints 0..l + 1 move it
  std::array<Pose, 3> link;
  Pose tip;                    ///< fingertip body pose (world)
};

/// Forward kinematics of the finger mounted on a hand at `hand` with joints q.
FingerKinematics FingerForward(const FingerModel& f, const Pose& hand, const Vec4& q);

/// Point Jacobian: the velocity of a material point at world position p of link
/// `link` (1 proximal .. 3 distal, the fingertip's) is J * qdot (one column per
/// joint; the columns of the joints past the link are zero).
Mat34 FingerPointJacobian(const FingerKinematics& k, const Vec3& p, int link = 3);

/// Angular Jacobian of link `link`: its angular velocity is J * qdot.
Mat34 FingerAngularJacobian(const FingerKinematics& k, int link = 3);

/// Clamps joints to their limits (scene setup, motor targets, inverse kinematics;
/// in the step the limits are rows of the solve, core/joint_limits.h).
Vec4 ClampJoints(const FingerModel& f, const Vec4& q);

/// Joint angles that bring the fingertip centre to `target` (hand frame), by damped
/// least squares from `q0`, within the limits. Returns the residual distance (m).
double FingerInverse(const FingerModel& f, const Vec3& target, const Vec4& q0, Vec4* q);

}  // namespace gs
