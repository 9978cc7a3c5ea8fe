// The contact space's model of a step against what the step really does: a contact
// that the solver leaves strictly inside the friction cone (sticking) must not slip.
// The solver only sees the linearised relative motion q + W r of the two material
// points; the bodies then move by their own kinematics (finger forward kinematics,
// rotations of squashed fingertips). Two mismatches made held objects creep: the
// finite-difference free slip of a finger (its curvature term when the motor's pull
// and the contact's push cancel) and the lever arm to the rest anchor instead of the
// displaced contact point of a deformable body.
#include "core/world.h"
#include "operator_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace gs {
namespace {

struct Snapshot {
  std::vector<Pose> pose;
  std::vector<std::vector<Vec3>> u;
};

Snapshot Take(const World& w) {
  Snapshot s;
  for (const Body& b : w.bodies) {
    s.pose.push_back(b.pose);
    s.u.push_back(b.u);
  }
  return s;
}

// world position of a contact side's material point: anchor + interpolated u, posed
Vec3 MaterialPoint(const ContactRow& row, int s, const Pose& pose, const std::vector<Vec3>& u) {
  const ContactSide& side = row.side[s];
  Vec3 x = row.contact.anchor[s];
  for (int k = 0; k < side.count; ++k) x += side.w[k] * u[side.idx[k]];
  return pose.Apply(x);
}

struct SlipCheck {
  int sticking = 0;         // contacts strictly inside the cone, over all checked steps
  double max_stick_slip = 0;  // their largest tangential slip over one step (m)
};

// steps the world `steps` times, checking the steps from `from` on
SlipCheck StepAndCheck(World& w, int steps, int from) {
  SlipCheck out;
  for (int i = 0; i < steps; ++i) {
    const Snapshot before = Take(w);
    w.Step();
    EXPECT_FALSE(w.profile.rejected);
    EXPECT_TRUE(w.profile.converged) << "step " << i << " residual " << w.profile.residual;
    if (i < from) continue;
    for (const ContactRow& row : w.rows) {
      const double fn = row.r[0], ft = row.r.tail<2>().norm();
      if (!(fn > 1e-4) || ft > 0.98 * row.mu * fn) continue;
      Vec3 rel = Vec3::Zero();
      for (int s = 0; s < 2; ++s) {
        const int b = row.contact.body[s];
        const Vec3 start = MaterialPoint(row, s, before.pose[b], before.u[b]);
        const Vec3 end = MaterialPoint(row, s, w.bodies[b].pose, w.bodies[b].u);
        rel += row.side[s].sign * (end - start);
      }
      const double slip = (row.frame.bottomRows<2>() * rel).norm();
      ++out.sticking;
      out.max_stick_slip = std::max(out.max_stick_slip, slip);
    }
  }
  return out;
}

DeformationParams SoftTip() {
  DeformationParams d;
  d.model = EDeformation::Gaussian;
  d.stiffness = 300;
  d.damping = 1;
  d.influence_radius = 0.0015;
  return d;
}

TEST(ContactModel, FingerPressingOnATableDoesNotCreepWhereItSticks) {
  World w;
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-10;
  w.params.solver.max_iterations = 500;
  w.params.default_friction = 0.8;
  BodySpec table;
  table.name = "table";
  table.is_plane = true;
  const int plane = AddBody(w, table);
  ASSERT_GE(plane, 0);

  Finger f;
  f.name = "index";
  f.model.link_lengths = {0.035, 0.025, 0.018};
  f.model.limits = {{{-0.6, 0.6}, {-0.2, 1.6}, {0.0, 1.8}, {0.0, 1.6}}};
  f.q = Vec4(0.0, 0.3, 0.6, 0.5);
  f.motor_stiffness = 2.0;
  f.motor_damping = 0.02;
  f.joint_damping = 0.005;
  BodySpec tip;
  tip.name = "tip";
  tip.shape.type = EShape::Ellipsoid;
  tip.shape.semi_axes = Vec3(0.008, 0.008, 0.011);
  tip.geometry.points = 2400;
  tip.geometry.control_points = 320;
  tip.deformation = SoftTip();
  tip.motion = EMotion::Fingertip;
  tip.pose = FingerForward(f.model, Pose{}, f.q).tip;
  f.body = AddBody(w, tip);
  ASSERT_GE(f.body, 0);
  // the table just under the fingertip's lowest control point
  double lowest = 1e9;
  for (const Vec3& c : w.bodies[f.body].geometry.tree.control_points())
    lowest = std::min(lowest, tip.pose.Apply(c).z());
  w.bodies[plane].pose = Pose::Translation(Vec3(0, 0, lowest + 2e-4));
  w.bodies[plane].pose_prev = w.bodies[plane].pose;
  // the first flexion turns the whole finger down: the fingertip presses on the table and drags along it
  f.q_target = f.q + Vec4(0.0, 0.1, 0.0, 0.0);
  w.hand.fingers.push_back(f);
  w.Finalize();

  const SlipCheck c = StepAndCheck(w, 400, 200);
  ASSERT_GT(c.sticking, 100) << "the scene should hold the fingertip in sticking contacts";
  // sticking within the solver's tolerance: under 1 nm per step (1 um/s; measured
  // 2e-14 m); the finite-difference free slip left 9e-7 m per step here, and the
  // lever arm to the rest anchor 1e-5 m
  EXPECT_LT(c.max_stick_slip, 1e-9);
  double fn = 0;
  for (const ContactRow& r : w.rows) fn += r.r[0];
  EXPECT_GT(fn, 0.1);  // it does press

  // the finger's side of every contact keeps its H and A^-1 H^T in the world's pool;
  // assembled through the solver's operator, W is symmetric and its diagonal blocks
  // are the contact space's (a wrong sign or transpose in either breaks one)
  int finger_sides = 0;
  for (const ContactRow& r : w.rows)
    for (const ContactSide& s : r.side) finger_sides += s.jacobian >= 0 ? 1 : 0;
  EXPECT_EQ(finger_sides, static_cast<int>(w.rows.size()));
  test::ExpectOperatorMatchesContactSpace(w);
}

TEST(ContactModel, SquashedFingertipHeldByFrictionDoesNotCreep) {
  // a free, soft, driven fingertip carrying a weight against a fixed wall by friction
  // alone: the friction torque turns it, which moves its squashed contact points
  World w;
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-10;
  w.params.solver.max_iterations = 500;
  w.params.default_friction = 0.9;
  BodySpec wall;
  wall.name = "wall";
  wall.is_plane = true;
  // plane z = 0 of its frame, normal +z: turned so that the normal is +x, at x = 0
  wall.pose = Pose::FromAxisAngle(Vec3::UnitY(), M_PI / 2);
  ASSERT_GE(AddBody(w, wall), 0);
  BodySpec t;
  t.name = "tip";
  t.shape.type = EShape::Sphere;
  t.shape.radius = 0.008;
  t.geometry.points = 2400;
  t.geometry.control_points = 320;
  t.mass = 0.03;
  t.deformation = SoftTip();
  t.deformation.damping = 0.5;
  const Pose target = Pose::Translation(Vec3(0.0078, 0, 0.05));
  t.pose = target;
  t.drive.enabled = true;
  // pushed into the wall with 1 N (target frame x is world x: the force is -x),
  // free vertically: only friction carries the weight (0.29 N of 0.9 N available)
  t.drive.stiffness = Vec3(0, 3000, 0);
  t.drive.damping = Vec3(0.5, 20, 0.5);
  t.drive.angular_stiffness = Vec3::Constant(0.5);
  t.drive.angular_damping = Vec3::Constant(0.01);
  t.drive.force = Vec3(-1.0, 0, 0);
  t.drive.target = target;
  const int tip = AddBody(w, t);
  ASSERT_GE(tip, 0);
  w.Finalize();

  const SlipCheck c = StepAndCheck(w, 600, 300);
  ASSERT_GT(c.sticking, 100);
  // measured 7e-15 m per step; with the lever arm to the rest anchor, 1.8e-7 m
  // (0.1 mm/s of creep)
  EXPECT_LT(c.max_stick_slip, 1e-9);
  // and it is held: no creep over the checked steps
  EXPECT_LT(std::abs(w.bodies[tip].velocity.z()), 1e-6);
  EXPECT_NEAR(w.bodies[tip].pose.t.z(), 0.05, 2e-3);
}

}  // namespace
}  // namespace gs

namespace gs {
namespace {

struct Rest {
  double drift = 0.0;  ///< the most the centre moved across the table (m)
  double spin = 0.0;   ///< the fastest it turned (rad/s)
};

// a soft ball (radius r, `points` / `control` sampled) let go where it rests on a
// table, stepped 0.3 s
Rest BallAtRest(double r, int points, int control, bool common_normal) {
  World w;
  w.params.collision.common_normal = common_normal;
  BodySpec table;
  table.name = "table";
  table.is_plane = true;
  table.motion = EMotion::Fixed;
  AddBody(w, table);
  BodySpec ball;
  ball.name = "ball";
  ball.shape.type = EShape::Sphere;
  ball.shape.radius = r;
  ball.geometry.points = points;
  ball.geometry.control_points = control;
  ball.mass = 0.15;
  ball.linear_damping = 0.02;
  ball.angular_damping = 1e-5;
  ball.deformation.model = EDeformation::Gaussian;
  ball.deformation.stiffness = 20000;
  ball.deformation.damping = 20;
  ball.deformation.influence_radius = 0.002;
  ball.pose = Pose::Translation(Vec3(0.0, 0.0, r - 5e-5));
  const int b = AddBody(w, ball);
  w.Finalize();
  const Vec3 start = w.bodies[b].pose.t;
  Rest out;
  for (int i = 0; i < 300; ++i) {
    w.Step();
    out.drift = std::max(out.drift, (w.bodies[b].pose.t - start).head<2>().norm());
    out.spin = std::max(out.spin, w.bodies[b].angular_velocity.norm());
  }
  return out;
}

}  // namespace

// A ball at rest on a table stays there. Its control points touch the analytic plane
// as the corners of a polyhedron; each normal force turns the ball about where the
// smooth surface touches the plane (Contact::touch, from the leaf's curvature), as
// for two sampled surfaces, so that the forces hold it the way a round ball is held.
// With the forces at the control points (common_normal off) a 3 cm ball of 1,300
// control points rocks 0.7 mm within 0.3 s and rolls millimetres away; with them
// where it touches, it creeps 0.016 mm (the sampled surface is round to within
// micrometres, and nothing resists rolling).
TEST(ContactModel, ABallLeftAtRestOnATableStaysWhereItIs) {
  const Rest on = BallAtRest(0.03, 10000, 1300, true);
  const Rest off = BallAtRest(0.03, 10000, 1300, false);
  std::printf("drift %.4f mm, spin %.4f rad/s (forces at the points: %.4f mm, %.4f rad/s)\n", 1e3 * on.drift, on.spin,
              1e3 * off.drift, off.spin);
  EXPECT_LT(on.drift, 5e-5);
  EXPECT_LT(on.spin, 0.02);
  EXPECT_GT(off.drift, 2e-4);  // the scene tells the two apart
}

}  // namespace gs
