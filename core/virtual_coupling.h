// Virtual coupling: a tracked target pose drives a free body through the body's
// Drive, a 6D damped spring that free motion treats implicitly. What this adds
// on top of Drive, so that a tracker jump cannot inject unbounded energy:
//   - the spring's target is pulled toward the body until the spring force is
//     within max_force and its torque within max_torque (Drive::max_force only
//     bounds the linear spring, not the implicit stiffness that acts on the step);
//   - the damping acts on the velocity relative to the target's (a feed-forward
//     force D v_target, itself bounded by max_force), so a moving target is
//     followed without a lag of v D / K;
//   - the body's weight is compensated, so a fingertip floats where it is told.
// Isotropic gains. No allocation, no I/O.
#pragma once

#include "core/world.h"

namespace gs {

struct CouplingParams {
  double stiffness = 800.0;           ///< N/m
  double damping = 8.0;               ///< N s/m
  double angular_stiffness = 0.02;    ///< N m/rad
  double angular_damping = 2e-4;      ///< N m s/rad
  double max_force = 20.0;            ///< N, bound of the spring and of the feed-forward force
  double max_torque = 0.05;           ///< N m, bound of the angular spring and of the feed-forward torque
  bool gravity_compensation = true;
};

/// Points the body's drive at `target`, which moves with `velocity` (m/s, world) and
/// turns with `angular_velocity` (rad/s, world): the damping's feed-forward of both
/// (within max_force and max_torque) leaves no lag behind a target moving or turning
/// steadily. A target or velocity that is not finite is ignored (the drive is left as it was).
void SetCouplingTarget(Body& b, const Vec3& gravity, const CouplingParams& p, const Pose& target, const Vec3& velocity,
                       const Vec3& angular_velocity);

/// A limp coupling: no spring, only damping toward rest (and gravity compensation):
/// the body holds its place but pushes on nothing.
void ReleaseCoupling(Body& b, const Vec3& gravity, const CouplingParams& p);

/// The spring force of the drive at the body's current pose (N, world).
Vec3 CouplingSpringForce(const Body& b);

}  // namespace gs
