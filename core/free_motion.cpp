// Free motion (paper Figure 1, first stage): every articulation moves under
// external forces, motors and drives, without contact forces, with implicit
// Euler. For a free body with displacement dq = (dx, dtheta) over the step:
//   (M/dt^2 + B/dt + K_drive + D_drive/dt) dq = G_ext + M v/dt + K_drive e_drive
// (the inertial variant); the quasi-static model of the paper (eq. 15) drops M.
// For a finger, joint space, motors as implicit PD toward the joint targets:
//   ((B + K_d)/dt + K_p) dq = K_p (q_target - q),
// unclamped: the joint limits act in the solve (core/joint_limits.h).
// The inverse mobility A^-1 is kept: the solver maps contact forces through it
// (W_rigid = J (A)^-1 J^T, eq. 17). Deformation relaxes: u_free = (C D/dt) u.
#include <algorithm>

#include "core/world.h"

namespace gs {
namespace {

Vec3 RotationVector(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.axis() * aa.angle();
}

// A drive's damped spring at a body pose, implicit: the force and torque it
// exerts there, and the stiffness (K + D/dt) and angular stiffness (K_a + D_a/dt)
// the step's motion meets (gains in the target frame, the spring within max_force).
struct DriveTerms {
  Mat3 linear, angular;
  Vec3 force, torque;
};

DriveTerms Terms(const Drive& d, const Pose& pose, double dt) {
  const Mat3& Rt = d.target.R;
  const Mat3 K = Rt * d.stiffness.asDiagonal() * Rt.transpose();
  const Mat3 Ka = Rt * d.angular_stiffness.asDiagonal() * Rt.transpose();
  Vec3 spring = K * (d.target.t - pose.t);
  const double mag = spring.norm();
  if (mag > d.max_force) spring *= d.max_force / mag;
  DriveTerms t;
  t.linear = K + Rt * d.damping.asDiagonal() * Rt.transpose() / dt;
  t.angular = Ka + Rt * d.angular_damping.asDiagonal() * Rt.transpose() / dt;
  t.force = spring + Rt * d.force;
  t.torque = Ka * RotationVector(d.target.R * pose.R.transpose()) + Rt * d.torque;
  return t;
}

// A segment's drive (virtual coupling) on a finger, in joint space: the spring's
// force F and torque T at the segment's origin act on the joints as J^T (F, T), and
// its stiffness enters the joint-space matrix as J^T K J (the quasi-static model:
// the segment's weight acts, its inertia does not).
void AddSegmentDrive(const World& w, const Body& b, const Pose& pose, const FingerKinematics& k, int link, Mat4* A,
                     Vec4* g) {
  if (!b.drive.enabled) return;
  const DriveTerms d = Terms(b.drive, pose, w.params.dt);
  const Mat34 Jl = FingerPointJacobian(k, pose.t, link);
  const Mat34 Ja = FingerAngularJacobian(k, link);
  *A += Jl.transpose() * d.linear * Jl + Ja.transpose() * d.angular * Ja;
  *g += Jl.transpose() * (d.force + b.mass * w.params.gravity) + Ja.transpose() * d.torque;
}

// A finger in joint space: motors as implicit PD toward the joint targets, plus
// the drives of the segments it carries; A^-1 kept for the solve.
void FingerFreeMotion(const World& w, Finger& f, Articulation* a) {
  const double dt = w.params.dt;
  Mat4 A = Mat4::Zero();
  Vec4 g = Vec4::Zero();
  for (int j = 0; j < 4; ++j) {
    A(j, j) = (f.joint_damping + f.motor_damping) / dt + f.motor_stiffness;
    g[j] = f.motor_stiffness * (f.q_target[j] - f.q[j]);
  }
  const bool driven = f.segment_body[0] >= 0 || f.segment_body[1] >= 0 || f.segment_body[2] >= 0;
  if (driven) {
    // at the configuration the step starts from (the hand already moved)
    const FingerKinematics k = FingerForward(f.model, w.hand.pose, f.q);
    for (int l = 0; l < 3; ++l)
      if (f.segment_body[l] >= 0)
        AddSegmentDrive(w, w.bodies[f.segment_body[l]], k.link[l] * f.segment_offset[l], k, l + 1, &A, &g);
  }
  a->a_inv.setZero();
  a->dq_free.setZero();
  if (driven) {
    a->a_inv.topLeftCorner<4, 4>() = A.inverse();
  } else {
    for (int j = 0; j < 4; ++j) a->a_inv(j, j) = 1.0 / A(j, j);
  }
  a->dq_free.head<4>() = a->a_inv.topLeftCorner<4, 4>() * g;
}

}  // namespace

void MarkRejected(World& w, const char* reason) {
  if (!w.profile.rejected) w.profile.reject_reason = reason;
  w.profile.rejected = true;
}

/// The pose reached from `start` by the displacement (dx, dtheta).
Pose AdvancePose(const Pose& start, const Vec6& dq) {
  Pose p;
  p.t = start.t + dq.head<3>();
  const Vec3 dth = dq.tail<3>();
  const double angle = dth.norm();
  Mat3 R = start.R;
  if (angle > 0.0) R = Eigen::AngleAxisd(angle, dth / angle).toRotationMatrix() * start.R;
  // keep R orthonormal over millions of steps
  p.R = Quat(R).normalized().toRotationMatrix();
  return p;
}

void FreeMotion(World& w) {
  const double dt = w.params.dt;
  // pose_prev and q_prev hold the configuration at the end of the last step;
  // kinematic bodies and the hand may already have been moved to this step's pose

  // a hand carried by its palm starts the step where the palm ended the last one
  if (w.hand.carrier >= 0) w.hand.pose = w.bodies[w.hand.carrier].pose_prev * w.hand.carrier_offset;

  for (Articulation& a : w.articulations) {
    a.dq.setZero();
    if (a.finger >= 0) {
      FingerFreeMotion(w, w.hand.fingers[a.finger], &a);
      continue;
    }
    Body& b = w.bodies[a.body];
    const Mat3 I_world = b.pose.R * b.inertia * b.pose.R.transpose();
    const bool inertial = b.dynamics == EDynamics::Inertial;
    Mat3 A_lin = Mat3::Identity() * (b.linear_damping / dt);
    Mat3 A_ang = Mat3::Identity() * (b.angular_damping / dt);
    Vec3 g_lin = b.mass * w.params.gravity;
    Vec3 g_ang = Vec3::Zero();
    if (inertial) {
      A_lin += Mat3::Identity() * (b.mass / (dt * dt));
      A_ang += I_world / (dt * dt);
      g_lin += b.mass * b.velocity / dt;
      g_ang += I_world * b.angular_velocity / dt;
    }
    if (b.drive.enabled) {
      // damped spring to the target pose, implicit
      const DriveTerms d = Terms(b.drive, b.pose, dt);
      A_lin += d.linear;
      A_ang += d.angular;
      g_lin += d.force;
      g_ang += d.torque;
    }
    a.a_inv.setZero();
    a.a_inv.topLeftCorner<3, 3>() = A_lin.inverse();
    a.a_inv.bottomRightCorner<3, 3>() = A_ang.inverse();
    a.dq_free.head<3>() = a.a_inv.topLeftCorner<3, 3>() * g_lin;
    a.dq_free.tail<3>() = a.a_inv.bottomRightCorner<3, 3>() * g_ang;
  }

  // A non-finite input (a NaN target from a tracker, a force, a hand pose) makes the
  // free motion non-finite: the step is marked rejected here and the configuration
  // collision detection sees stays the last one, so that no stage works on NaN poses;
  // constrained motion then undoes the step (and sees the non-finite dq_free too).
  const bool hand_finite = w.hand.pose.t.allFinite() && w.hand.pose.R.allFinite();
  if (!hand_finite) {
    MarkRejected(w, "free motion: the hand pose is not finite");
    w.hand.pose = w.hand.pose_prev;
  }
  for (Body& b : w.bodies)
    if (b.motion == EMotion::Kinematic && !(b.pose.t.allFinite() && b.pose.R.allFinite())) {
      MarkRejected(w, "free motion: a kinematic body's pose is not finite");
      b.pose = b.pose_prev;
    }

  // tentative configuration after free motion: what collision detection sees
  for (Articulation& a : w.articulations) {
    const bool finite = a.dq_free.allFinite() && a.a_inv.allFinite();
    if (!finite) MarkRejected(w, "free motion: not finite (an input force, target or parameter)");
    if (a.finger >= 0) {
      // not clamped to the joint limits: the motors' pull past a limit is what the
      // limit rows of the solve must hold (core/joint_limits.h), and contacts are
      // linearised at this configuration, the one the solver starts from
      Finger& f = w.hand.fingers[a.finger];
      const Vec4 q_free = finite ? Vec4(f.q + a.dq_free.head<4>()) : f.q;
      f.kin = FingerForward(f.model, w.hand.pose, q_free);
      ForEachCarried(f, f.kin, [&](int body, const Pose& p) { w.bodies[body].pose = p; });
    } else {
      Body& b = w.bodies[a.body];
      b.pose = finite ? AdvancePose(b.pose_prev, a.dq_free) : b.pose_prev;
    }
  }

  // deformation relaxes toward the rest shape (the live points: the others are at rest)
  for (Body& b : w.bodies) {
    if (!b.deform.enabled()) continue;
    for (int j : b.live) {
      b.u_free[j] = b.deform.Relaxation(j) * b.u[j];
      b.u_acc[j].setZero();
    }
  }
}

}  // namespace gs
