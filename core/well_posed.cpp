#include "core/well_posed.h"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <cstdio>

namespace gs {
namespace {

// a free-motion matrix is refused below this ratio of its smallest to largest eigenvalue
constexpr double kMinConditionRatio = 1e-13;

bool Finite(double x) { return std::isfinite(x); }

std::string Fmt(const char* fmt, const std::string& name, double a = 0.0, double b = 0.0) {
  char msg[512];
  std::snprintf(msg, sizeof msg, fmt, name.c_str(), a, b);
  return msg;
}

bool IsRotation(const Mat3& R) {
  return R.allFinite() && (R.transpose() * R - Mat3::Identity()).norm() < 1e-6 && R.determinant() > 0.0;
}

// positive definite within kMinConditionRatio (and symmetric)
bool PositiveDefinite(const Mat3& m) {
  if (!m.allFinite()) return false;
  if ((m - m.transpose()).norm() > 1e-9 * m.norm()) return false;
  double lo, hi;
  SymmetricRange(m, &lo, &hi);
  return hi > 0.0 && lo > kMinConditionRatio * hi;
}

std::string CheckBody(const World& w, const Body& b) {
  const double dt = w.params.dt;
  if (!b.pose.t.allFinite() || !IsRotation(b.pose.R))
    return Fmt("body '%s': its pose is not finite or its orientation is not a rotation", b.name);
  if (!b.velocity.allFinite() || !b.angular_velocity.allFinite())
    return Fmt("body '%s': its velocity is not finite", b.name);
  if (b.motion == EMotion::Free) {
    if (!Finite(b.linear_damping) || b.linear_damping < 0.0 || !Finite(b.angular_damping) || b.angular_damping < 0.0)
      return Fmt("body '%s': damping must be finite and >= 0 (linear %g N s/m, angular %g N m s/rad)", b.name,
                 b.linear_damping, b.angular_damping);
    const bool inertial = b.dynamics == EDynamics::Inertial;
    if (inertial) {
      if (!Finite(b.mass) || b.mass <= 0.0)
        return Fmt("body '%s': a free inertial body needs a finite mass > 0 kg, got %g: its free motion would solve "
                   "0 * dq = m g",
                   b.name, b.mass);
      if (!PositiveDefinite(b.inertia)) {
        double lo = 0.0, hi = 0.0;
        if (b.inertia.allFinite()) SymmetricRange(b.inertia, &lo, &hi);
        return Fmt("body '%s': a free inertial body needs a symmetric positive definite inertia, got principal "
                   "moments from %g to %g kg m^2",
                   b.name, lo, hi);
      }
    } else if (!Finite(b.mass) || b.mass < 0.0) {
      return Fmt("body '%s': mass must be finite and >= 0 kg, got %g", b.name, b.mass);
    }
    const Drive& d = b.drive;
    if (d.enabled) {
      const bool gains_ok = d.stiffness.allFinite() && d.damping.allFinite() && d.angular_stiffness.allFinite() &&
                            d.angular_damping.allFinite() && d.stiffness.minCoeff() >= 0.0 &&
                            d.damping.minCoeff() >= 0.0 && d.angular_stiffness.minCoeff() >= 0.0 &&
                            d.angular_damping.minCoeff() >= 0.0;
      if (!gains_ok) return Fmt("body '%s': drive gains must be finite and >= 0", b.name);
      if (!d.force.allFinite() || !(d.max_force > 0.0) || std::isnan(d.max_force))
        return Fmt("body '%s': drive force must be finite and max_force > 0 N", b.name);
      if (!d.target.t.allFinite() || !IsRotation(d.target.R))
        return Fmt("body '%s': drive target pose is not finite or not a rotation", b.name);
    }
    // the free-motion matrices of free_motion.cpp (the rotation of the inertia and of
    // the drive gains into the world does not change their definiteness)
    Mat3 A_lin = Mat3::Identity() * (b.linear_damping / dt);
    Mat3 A_ang = Mat3::Identity() * (b.angular_damping / dt);
    if (inertial) {
      A_lin += Mat3::Identity() * (b.mass / (dt * dt));
      A_ang += b.inertia / (dt * dt);
    }
    if (d.enabled) {
      A_lin += Mat3(d.stiffness.asDiagonal()) + Mat3(d.damping.asDiagonal()) / dt;
      A_ang += Mat3(d.angular_stiffness.asDiagonal()) + Mat3(d.angular_damping.asDiagonal()) / dt;
    }
    if (!PositiveDefinite(A_lin))
      return Fmt("body '%s': its translation has no mobility bound: a quasi-static body needs linear damping > 0 "
                 "(or drive stiffness or damping on every axis); smallest eigenvalue of M/dt^2 + B/dt + K + D/dt is %g",
                 b.name, A_lin.diagonal().minCoeff());
    if (!PositiveDefinite(A_ang))
      return Fmt("body '%s': its rotation has no mobility bound: a quasi-static body needs angular damping > 0 "
                 "(or angular drive gains on every axis); smallest diagonal of I/dt^2 + B/dt + K + D/dt is %g",
                 b.name, A_ang.diagonal().minCoeff());
  }
  if (b.deform.enabled()) {
    const DeformationParams& p = b.deform.params();
    if (!Finite(p.damping) || p.damping < 0.0)
      return Fmt("body '%s': deformation damping must be finite and >= 0 N s/m, got %g", b.name, p.damping);
    if (p.model == EDeformation::Gaussian) {
      if (!Finite(p.stiffness) || p.stiffness <= 0.0)
        return Fmt("body '%s': deformation stiffness must be finite and > 0 N/m, got %g", b.name, p.stiffness);
      if (!Finite(p.influence_radius) || p.influence_radius <= 0.0)
        return Fmt("body '%s': influence radius must be finite and > 0 m, got %g", b.name, p.influence_radius);
    } else {
      if (!Finite(p.young_modulus) || p.young_modulus <= 0.0)
        return Fmt("body '%s': Young's modulus must be finite and > 0 Pa, got %g", b.name, p.young_modulus);
      if (!Finite(p.poisson_ratio) || p.poisson_ratio < 0.0 || p.poisson_ratio >= 0.5)
        return Fmt("body '%s': Poisson's ratio must be in [0, 0.5), got %g", b.name, p.poisson_ratio);
      if (!Finite(p.influence_radius) || p.influence_radius < 0.0)
        return Fmt("body '%s': influence radius must be finite and >= 0 m, got %g", b.name, p.influence_radius);
    }
  }
  return "";
}

std::string CheckFinger(const Finger& f) {
  for (double l : f.model.link_lengths)
    if (!Finite(l) || l <= 0.0) return Fmt("finger '%s': link lengths must be finite and > 0 m, got %g", f.name, l);
  for (const auto& lim : f.model.limits)
    if (!Finite(lim[0]) || !Finite(lim[1]) || lim[0] > lim[1])
      return Fmt("finger '%s': a joint limit is not finite or its low end %g exceeds its high end %g", f.name, lim[0],
                 lim[1]);
  if (!f.q.allFinite() || !f.q_target.allFinite()) return Fmt("finger '%s': joints are not finite", f.name);
  if (!f.model.base.t.allFinite() || !IsRotation(f.model.base.R) || !f.model.tip_offset.allFinite())
    return Fmt("finger '%s': base pose or fingertip offset is not finite", f.name);
  const bool segments = f.segment_body[0] >= 0 || f.segment_body[1] >= 0 || f.segment_body[2] >= 0;
  if (!segments && (!Finite(f.motor_stiffness) || f.motor_stiffness <= 0.0))
    return Fmt("finger '%s': motor stiffness must be finite and > 0 N m/rad, got %g", f.name, f.motor_stiffness);
  if (!Finite(f.motor_stiffness) || f.motor_stiffness < 0.0)
    return Fmt("finger '%s': motor stiffness must be finite and >= 0 N m/rad, got %g", f.name, f.motor_stiffness);
  if (!Finite(f.motor_damping) || f.motor_damping < 0.0 || !Finite(f.joint_damping) || f.joint_damping < 0.0)
    return Fmt("finger '%s': motor and joint damping must be finite and >= 0 (got %g and %g N m s/rad)", f.name,
               f.motor_damping, f.joint_damping);
  // a finger driven by its segments' springs alone goes limp when they release: its
  // joints then need damping to keep the joint-space matrix invertible
  if (segments && f.motor_stiffness + f.motor_damping + f.joint_damping <= 0.0)
    return Fmt("finger '%s': a finger driven by its segments needs motor stiffness or joint damping > 0", f.name);
  return "";
}

}  // namespace

void SymmetricRange(const Mat3& m, double* lo, double* hi) {
  const Eigen::SelfAdjointEigenSolver<Mat3> es(0.5 * (m + m.transpose()), Eigen::EigenvaluesOnly);
  *lo = es.eigenvalues()[0];
  *hi = es.eigenvalues()[2];
}

std::string WellPosedError(const World& w) {
  const WorldParams& p = w.params;
  const std::string world = "world";
  if (!Finite(p.dt) || p.dt <= 0.0) return Fmt("%s: the time step must be finite and > 0 s, got %g", world, p.dt);
  if (!p.gravity.allFinite()) return Fmt("%s: gravity is not finite", world);
  if (!Finite(p.solver.tolerance) || p.solver.tolerance <= 0.0 || p.solver.tolerance >= 1.0)
    return Fmt("%s: solver tolerance must be in (0, 1), got %g", world, p.solver.tolerance);
  if (p.solver.max_iterations < 1) return Fmt("%s: the solver needs at least one sweep, got %g", world, p.solver.max_iterations);
  if (!Finite(p.solver.over_relaxation) || p.solver.over_relaxation <= 0.0 || p.solver.over_relaxation >= 2.0)
    return Fmt("%s: over-relaxation must be in (0, 2), got %g", world, p.solver.over_relaxation);
  if (!Finite(p.default_friction) || p.default_friction < 0.0)
    return Fmt("%s: the friction coefficient must be finite and >= 0, got %g", world, p.default_friction);
  for (double mu : w.friction_)
    if (!Finite(mu) || mu < 0.0) return Fmt("%s: a pair's friction coefficient must be finite and >= 0, got %g", world, mu);
  if (!Finite(p.collision.contact_threshold) || p.collision.contact_threshold < 0.0)
    return Fmt("%s: the contact threshold must be finite and >= 0 m, got %g", world, p.collision.contact_threshold);
  if (!Finite(p.max_push_out_speed) || p.max_push_out_speed < 0.0)
    return Fmt("%s: the push-out speed must be finite and >= 0 m/s, got %g", world, p.max_push_out_speed);
  if (!Finite(p.joint_limit_margin) || p.joint_limit_margin < 0.0)
    return Fmt("%s: the joint-limit margin must be finite and >= 0 rad, got %g", world, p.joint_limit_margin);
  if (p.max_contacts < 1) return Fmt("%s: max_contacts must be >= 1, got %g", world, p.max_contacts);
  if (!w.hand.pose.t.allFinite() || !IsRotation(w.hand.pose.R)) return Fmt("%s: the hand pose is not finite", world);
  for (const Body& b : w.bodies) {
    const std::string e = CheckBody(w, b);
    if (!e.empty()) return e;
  }
  for (const Finger& f : w.hand.fingers) {
    const std::string e = CheckFinger(f);
    if (!e.empty()) return e;
  }
  return "";
}

}  // namespace gs
