#include "core/virtual_coupling.h"

#include <algorithm>

namespace gs {
namespace {

void SetGains(Body& b, const CouplingParams& p, bool spring) {
  Drive& d = b.drive;
  d.enabled = true;
  d.stiffness = Vec3::Constant(spring ? p.stiffness : 0.0);
  d.damping = Vec3::Constant(p.damping);
  d.angular_stiffness = Vec3::Constant(spring ? p.angular_stiffness : 0.0);
  d.angular_damping = Vec3::Constant(p.angular_damping);
  d.max_force = p.max_force;
}

Vec3 Clamped(const Vec3& v, double max_norm) {
  const double n = v.norm();
  return n > max_norm && n > 0.0 ? Vec3(v * (max_norm / n)) : v;
}

}  // namespace

void SetCouplingTarget(Body& b, const Vec3& gravity, const CouplingParams& p, const Pose& target, const Vec3& velocity,
                       const Vec3& angular_velocity) {
  // a non-finite target (a corrupt tracker sample) is ignored: the drive keeps its last target
  if (!target.t.allFinite() || !target.R.allFinite() || !velocity.allFinite() || !angular_velocity.allFinite()) return;
  SetGains(b, p, true);
  Drive& d = b.drive;
  // the spring force K (x_t - x) stays within max_force
  Vec3 offset = target.t - b.pose.t;
  if (p.stiffness > 0.0) offset = Clamped(offset, p.max_force / p.stiffness);
  d.target.t = b.pose.t + offset;
  // the spring torque K_a theta stays within max_torque
  const Eigen::AngleAxisd rel(target.R * b.pose.R.transpose());
  double angle = rel.angle();
  if (p.angular_stiffness > 0.0) angle = std::min(angle, p.max_torque / p.angular_stiffness);
  d.target.R = angle > 0.0 ? Mat3(Eigen::AngleAxisd(angle, rel.axis()).toRotationMatrix() * b.pose.R) : b.pose.R;
  // feed-forward of the target's velocity through the damping, plus the weight
  Vec3 f = Clamped(p.damping * velocity, p.max_force);
  if (p.gravity_compensation) f -= b.mass * gravity;
  d.force = d.target.R.transpose() * f;  // Drive::force is in the target frame
  d.torque = d.target.R.transpose() * Clamped(p.angular_damping * angular_velocity, p.max_torque);
}

void ReleaseCoupling(Body& b, const Vec3& gravity, const CouplingParams& p) {
  SetGains(b, p, false);
  b.drive.target = b.pose;
  b.drive.force = p.gravity_compensation ? Vec3(b.pose.R.transpose() * (-b.mass * gravity)) : Vec3::Zero();
  b.drive.torque.setZero();
}

Vec3 CouplingSpringForce(const Body& b) {
  const Drive& d = b.drive;
  if (!d.enabled) return Vec3::Zero();
  const Mat3& Rt = d.target.R;
  return Clamped(Rt * d.stiffness.asDiagonal() * Rt.transpose() * (d.target.t - b.pose.t), d.max_force);
}

}  // namespace gs
