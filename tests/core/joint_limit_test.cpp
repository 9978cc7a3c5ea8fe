// Joint limits as unilateral rows of the contact solve (core/joint_limits.h): a
// finger held at a limit by the solver itself (no clamp after the solve), the limit
// torque carrying what the motors and the contacts push past it, and Signorini
// complementarity of limit rows and contacts together in every solver path.
#include <gtest/gtest.h>

#include <cmath>

#include "core/fc_fallback.h"
#include "core/fc_problem.h"
#include "core/joint_limits.h"
#include "core/world.h"
#include "soft_bodies.h"

namespace gs {
namespace {

constexpr double kStiffness = 2.0;  // motor, N m/rad

Finger MakeFinger(const Vec4& q, const Vec4& target) {
  Finger f;
  f.name = "index";
  f.model.link_lengths = {0.035, 0.025, 0.018};
  f.model.limits = {{{-0.6, 0.6}, {-0.2, 1.6}, {0.0, 1.8}, {0.0, 1.6}}};
  f.q = q;
  f.q_target = target;
  f.motor_stiffness = kStiffness;
  f.motor_damping = 0.02;
  f.joint_damping = 0.005;
  return f;
}

// the limit row of joint j's end (0 low, 1 high), or null
const LimitRow* FindLimit(const World& w, int joint, int end) {
  for (const LimitRow& l : w.limit_rows)
    if (l.joint == joint && l.sign == (end == 0 ? 1.0 : -1.0)) return &l;
  return nullptr;
}

// the joint's distance to the row's limit after the step (rad, >= 0 when feasible)
double JointGap(const World& w, const LimitRow& l) {
  const Finger& f = w.hand.fingers[l.finger];
  const double limit = f.model.limits[l.joint][l.sign > 0.0 ? 0 : 1];
  return l.sign * (f.q[l.joint] - limit);
}

TEST(JointLimit, FingerDrivenPastALimitStopsThereAndTheRowCarriesTheMotorTorque) {
  World w;
  w.params.gravity.setZero();
  // no fingertip: nothing but the motor and the limit act on the joints
  w.hand.fingers.push_back(MakeFinger(Vec4(0, 1.0, 0.3, 0.2), Vec4(0, 2.0, 0.3, 0.2)));
  w.Finalize();
  const double upper = 1.6;
  bool reached = false;
  for (int i = 0; i < 300; ++i) {
    w.Step();
    ASSERT_FALSE(w.profile.rejected) << i;
    ASSERT_TRUE(w.profile.converged) << i;
    const double q = w.hand.fingers[0].q[1];
    // held by the solver: never past the limit (no clamp after the solve)
    ASSERT_LE(q, upper + 1e-9) << i;
    const LimitRow* l = FindLimit(w, 1, 1);
    const bool at_limit = std::abs(q - upper) <= 1e-9;
    // the limit pushes exactly when the joint sits at it
    EXPECT_EQ(l != nullptr && l->r > 0.0, at_limit) << "step " << i << " q " << q;
    reached |= at_limit;
  }
  ASSERT_TRUE(reached);
  // at rest at the limit: only joint 1's upper limit is near, and its torque is the
  // motor's pull K (q_target - q) = 2 x 0.4 N m, pushing back (negative)
  ASSERT_EQ(w.limit_rows.size(), 1u);
  const LimitRow& l = w.limit_rows[0];
  EXPECT_EQ(l.joint, 1);
  EXPECT_NEAR(l.Torque(), -kStiffness * (2.0 - upper), 1e-9);
  EXPECT_NEAR(w.hand.fingers[0].q[1], upper, 1e-9);
  // the force is warm started by the row's slot for the next step
  EXPECT_EQ(w.limit_warm[l.slot], l.r);

  // a target back inside: the unilateral row lets go at once and the joint leaves
  w.hand.fingers[0].q_target[1] = 1.0;
  for (int i = 0; i < 300; ++i) {
    w.Step();
    const LimitRow* near = FindLimit(w, 1, 1);
    EXPECT_TRUE(near == nullptr || near->r == 0.0) << i;
  }
  EXPECT_NEAR(w.hand.fingers[0].q[1], 1.0, 1e-3);
  EXPECT_TRUE(w.limit_rows.empty());
}

TEST(JointLimit, JointStartingPastItsLimitIsPushedBackAtTheBoundedSpeed) {
  // like a starting overlap (max_push_out_speed): a joint set 0.1 rad past its limit
  // is not snapped back in one step but returned at most 0.1 m/s at the row's lever
  World w;
  w.params.gravity.setZero();
  w.hand.fingers.push_back(MakeFinger(Vec4(0, 1.7, 0.3, 0.2), Vec4(0, 1.7, 0.3, 0.2)));
  w.Finalize();
  const double lever = 0.035 + 0.025 + 0.018;  // joint 1 moves the whole finger
  const double per_step = w.params.max_push_out_speed * w.params.dt / lever;
  double prev = 1.7;
  int steps = 0;
  while (w.hand.fingers[0].q[1] > 1.6 + 1e-12 && steps < 1000) {
    w.Step();
    ++steps;
    const double q = w.hand.fingers[0].q[1];
    EXPECT_LE(prev - q, per_step * (1 + 1e-9)) << steps;
    EXPECT_LT(q, prev) << steps;
    prev = q;
  }
  EXPECT_NEAR(steps, 0.1 / per_step, 2.0);
  for (int i = 0; i < 10; ++i) w.Step();
  EXPECT_NEAR(w.hand.fingers[0].q[1], 1.6, 1e-9);
  ASSERT_EQ(w.limit_rows.size(), 1u);
  EXPECT_NEAR(w.limit_rows[0].Torque(), -kStiffness * 0.1, 1e-9);  // the motor's pull toward 1.7
}

// A finger held with its two distal joints at their lower limits (the motors pull
// them 0.1 rad past), palm up; a free rigid ball pushed down onto the fingertip by
// a constant force F, centred by lateral springs. Joint 1 is 0.2 rad from its
// limit: its motor alone holds it.
struct PushScene {
  World w;
  int ball = -1;
  double force = 0.5;  // N
};

void BuildPushScene(PushScene* s, double friction) {
  World& w = s->w;
  w.params.gravity.setZero();
  w.params.default_friction = friction;
  w.params.solver.tolerance = 1e-10;
  w.params.solver.max_iterations = 500;
  // the hand turned over: the finger's flexion curls toward world +z, so a push
  // down on the fingertip bends the joints toward their lower limits
  w.hand.pose = Pose::FromAxisAngle(Vec3::UnitX(), M_PI, Vec3::Zero());
  Finger f = MakeFinger(Vec4::Zero(), Vec4(0, 0, -0.1, -0.1));
  BodySpec tip;
  tip.name = "tip";
  tip.shape.type = EShape::Ellipsoid;
  tip.shape.semi_axes = Vec3(0.008, 0.008, 0.011);
  tip.geometry.points = 1200;
  tip.geometry.control_points = 160;
  tip.deformation.model = EDeformation::Gaussian;
  tip.deformation.stiffness = 300;
  tip.deformation.damping = 1;
  tip.deformation.influence_radius = 0.0015;
  tip.motion = EMotion::Fingertip;
  tip.pose = FingerForward(f.model, w.hand.pose, f.q).tip;
  f.body = AddBody(w, tip);
  ASSERT_GE(f.body, 0);
  // the ball just above the fingertip's top
  const Vec3 top = tip.pose.t + Vec3(0, 0, 0.008);
  BodySpec ball = test::SoftBall(top + Vec3(0, 0, 0.01 + 1e-4), false);
  ball.drive.enabled = true;
  ball.drive.target = ball.pose;
  ball.drive.stiffness = Vec3(50, 50, 0);
  ball.drive.damping = Vec3(2, 2, 2);
  ball.drive.angular_stiffness = Vec3::Constant(0.01);
  ball.drive.angular_damping = Vec3::Constant(1e-3);
  ball.drive.force = Vec3(0, 0, -s->force);
  s->ball = AddBody(w, ball);
  ASSERT_GE(s->ball, 0);
  w.hand.fingers.push_back(f);
  w.Finalize();
}

// the contact forces on body b (world, N)
Vec3 ContactForceOn(const World& w, int b) {
  Vec3 f = Vec3::Zero();
  for (const ContactRow& r : w.rows)
    for (const ContactSide& s : r.side)
      if (s.body == b) f += s.sign * (r.frame.transpose() * r.r);
  return f;
}

// the generalized force of the contacts on the finger: sum of h^T r over its sides
Vec4 ContactTorques(const World& w) {
  Vec4 t = Vec4::Zero();
  for (const ContactRow& r : w.rows)
    for (const ContactSide& s : r.side)
      if (s.jacobian >= 0) t += (w.side_jacobians[s.jacobian].h.transpose() * r.r).head<4>();
  return t;
}

TEST(JointLimit, ObjectPushingAFingerAtItsLimitsMeetsTheTorqueTheLimitsDeliver) {
  PushScene s;
  BuildPushScene(&s, 0.8);
  World& w = s.w;
  const Finger& f = w.hand.fingers[0];
  for (int i = 0; i < 800; ++i) {
    w.Step();
    ASSERT_FALSE(w.profile.rejected) << i;
    ASSERT_TRUE(w.profile.converged) << i;
    // the distal joints never yield past their limits
    EXPECT_GE(f.q[2], -1e-9) << i;
    EXPECT_GE(f.q[3], -1e-9) << i;
  }
  ASSERT_GT(w.rows.size(), 0u);
  // at rest: the ball still, carried by the finger with the whole force F
  EXPECT_LT(w.bodies[s.ball].velocity.norm(), 1e-5);
  const Vec3 on_ball = ContactForceOn(w, s.ball);
  EXPECT_NEAR(on_ball.z(), s.force, 1e-3 * s.force);
  // the distal joints sit at their limits, pushed by their rows
  const LimitRow* l2 = FindLimit(w, 2, 0);
  const LimitRow* l3 = FindLimit(w, 3, 0);
  ASSERT_TRUE(l2 && l3);
  EXPECT_NEAR(f.q[2], 0.0, 1e-9);
  EXPECT_NEAR(f.q[3], 0.0, 1e-9);
  EXPECT_GT(l2->r, 0.0);
  EXPECT_GT(l3->r, 0.0);
  EXPECT_EQ(FindLimit(w, 1, 0), nullptr);  // joint 1 yields to its motor, 0.2 rad from its limit
  // each joint's balance at rest: motor + contacts + limit = 0
  const Vec4 contact = ContactTorques(w);
  for (int j = 0; j < 4; ++j) {
    const LimitRow* l = FindLimit(w, j, 0);
    const double limit = l ? l->Torque() : 0.0;
    const double motor = kStiffness * (f.q_target[j] - f.q[j]);
    EXPECT_NEAR(motor + contact[j] + limit, 0.0, 1e-6) << "joint " << j;
  }
  // analytic: joints 2 and 3 turn about parallel axes L2 apart along the (nearly
  // level) middle link, so the ball's push F loads joint 2 by F L2 cos(q1) more than
  // joint 3 (its motor's pull is the same on both)
  const double arm = f.model.link_lengths[1] * std::cos(f.q[1]);
  EXPECT_NEAR(l2->Torque() - l3->Torque(), s.force * arm, 0.01 * s.force * arm);
  // the fingertip's contacts and the limits couple through A^-1 in the step's problem
  FcProblem p;
  AssembleContactProblem(w, &p);
  const int nc = static_cast<int>(w.rows.size());
  ASSERT_EQ(p.contacts, nc + static_cast<int>(w.limit_rows.size()));
  const Eigen::MatrixXd W(p.W);
  double coupling = 0.0;
  for (int k = nc; k < p.contacts; ++k) {
    EXPECT_NEAR(W(3 * k, 3 * k), w.limit_rows[k - nc].w, 1e-12 * w.limit_rows[k - nc].w);
    for (int c = 0; c < nc; ++c) coupling = std::max(coupling, std::abs(W(3 * c, 3 * k)));
  }
  EXPECT_GT(coupling, 0.0);
  EXPECT_LE((W - W.transpose()).cwiseAbs().maxCoeff(), 1e-9 * W.cwiseAbs().maxCoeff());
}

enum class EPath { Nsgs, Newton, NormalsOnly };

// Signorini for every row of the step's problem (contacts and limits): r_n >= 0,
// u_n = (W r + q)_n >= 0, r_n u_n = 0, as the natural residual min(w_nn r_n, u_n)
// in metres; the limit rows' u is also their joint's real gap after the step.
void ExpectComplementarity(World& w, double tol) {
  FcProblem p;
  Eigen::VectorXd r;
  AssembleContactProblem(w, &p, &r);
  const Eigen::VectorXd u = p.W * r + p.q;
  const int nc = static_cast<int>(w.rows.size());
  for (int c = 0; c < p.contacts; ++c) {
    const double wnn = p.W.coeff(3 * c, 3 * c);
    EXPECT_GE(r[3 * c], 0.0) << "row " << c;
    EXPECT_LE(std::abs(std::min(wnn * r[3 * c], u[3 * c])), tol) << "row " << c << " of " << nc << " contacts";
  }
  for (size_t k = 0; k < w.limit_rows.size(); ++k) {
    const LimitRow& l = w.limit_rows[k];
    EXPECT_NEAR(u[3 * (nc + k)], l.lever * JointGap(w, l), 1e-12) << "limit " << k;
  }
}

void RunComplementarity(EPath path) {
  PushScene s;
  BuildPushScene(&s, path == EPath::NormalsOnly ? 0.0 : 0.8);
  World& w = s.w;
  if (path == EPath::Newton) w.params.solver.max_iterations = 2;  // NSGS ends short: Newton continues
  int newton = 0, with_limits = 0;
  for (int i = 0; i < 300; ++i) {
    w.Step();
    ASSERT_FALSE(w.profile.rejected) << i;
    ASSERT_TRUE(w.profile.converged) << i << " residual " << w.profile.residual;
    newton += w.profile.newton_steps > 0 ? 1 : 0;
    if (i < 100 || w.limit_rows.empty()) continue;
    ++with_limits;
    ExpectComplementarity(w, 1e-12);
  }
  EXPECT_GT(with_limits, 100);
  if (path == EPath::Newton) {
    EXPECT_GT(newton, 100);
  }
  if (path == EPath::NormalsOnly) {
    EXPECT_GT(w.profile.work.local_solves_normal, 0);
  }
}

TEST(JointLimit, LimitsAndContactsAreComplementaryUnderGaussSeidel) { RunComplementarity(EPath::Nsgs); }
TEST(JointLimit, LimitsAndContactsAreComplementaryUnderNewton) { RunComplementarity(EPath::Newton); }
TEST(JointLimit, LimitsAndFrictionlessContactsAreComplementary) { RunComplementarity(EPath::NormalsOnly); }

// The step's problem as exported (run --export-fclib, bench): its limit rows are
// frictionless contacts with zero tangent blocks, which the explicit solvers
// (NSGS, Newton, auto) solve from zero to the step's limit forces.
TEST(JointLimit, ExportedProblemWithLimitRowsIsSolvedByEveryExplicitMethod) {
  PushScene s;
  BuildPushScene(&s, 0.8);
  for (int i = 0; i < 400; ++i) s.w.Step();
  FcProblem p;
  Eigen::VectorXd stepped;
  AssembleContactProblem(s.w, &p, &stepped);
  ASSERT_STREQ(CheckFcProblem(p), "");
  const int nc = static_cast<int>(s.w.rows.size());
  ASSERT_EQ(s.w.limit_rows.size(), 2u);
  for (EFcMethod m : {EFcMethod::Nsgs, EFcMethod::Newton, EFcMethod::Auto}) {
    FcMethodParams params;
    params.tolerance = 1e-10;
    Eigen::VectorXd r;
    const FcMethodResult res = SolveFcMethod(p, m, params, &r);
    EXPECT_TRUE(res.converged) << res.Summary();
    for (int k = 0; k < 2; ++k) {
      const int c = nc + k;
      EXPECT_NEAR(r[3 * c], stepped[3 * c], 1e-4 * stepped[3 * c]) << FcMethodName(m) << " limit " << k;
      EXPECT_EQ(r[3 * c + 1], 0.0);
      EXPECT_EQ(r[3 * c + 2], 0.0);
    }
  }
}

}  // namespace
}  // namespace gs
