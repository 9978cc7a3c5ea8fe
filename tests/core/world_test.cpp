#include "core/world.h"

#include <gtest/gtest.h>

#include <cmath>

namespace gs {
namespace {

int AddPlane(World& w, const Pose& pose) {
  Body b;
  b.name = "plane";
  b.motion = EMotion::Fixed;
  BuildPlaneGeometry(&b.geometry);
  b.pose = pose;
  w.bodies.push_back(std::move(b));
  return static_cast<int>(w.bodies.size()) - 1;
}

int AddBody(World& w, const ShapeDesc& shape, int points, int cps, double mass, const Pose& pose,
            const DeformationParams& def) {
  Body b;
  b.name = "body";
  b.motion = EMotion::Free;
  b.mass = mass;
  b.inertia = SolidInertia(shape, mass);
  b.pose = pose;
  GeometryOptions opt;
  opt.points = points;
  opt.control_points = cps;
  EXPECT_EQ(BuildShapeGeometry(shape, opt, &b.geometry), EGeometryError::None);
  b.deform.Build(b.geometry.tree.control_points(), b.geometry.area / cps, def, w.params.dt);
  w.bodies.push_back(std::move(b));
  return static_cast<int>(w.bodies.size()) - 1;
}

bool AllFinite(const World& w) {
  for (const Body& b : w.bodies) {
    if (!b.pose.R.allFinite() || !b.pose.t.allFinite()) return false;
    for (const Vec3& u : b.u)
      if (!u.allFinite()) return false;
  }
  return true;
}

TEST(World, DeformableSphereSettlesOnAPlaneAndRelaxesWhenLifted) {
  World w;
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-6;
  w.params.solver.max_iterations = 200;
  AddPlane(w, Pose{});
  ShapeDesc s;
  s.type = EShape::Sphere;
  s.radius = 0.01;
  DeformationParams def;
  def.model = EDeformation::Gaussian;
  def.stiffness = 500;
  def.damping = 1;
  def.influence_radius = 0.002;
  const int ball = AddBody(w, s, 3000, 400, 0.05, Pose::Translation(Vec3(0, 0, 0.0102)), def);
  w.bodies[ball].linear_damping = 0.05;
  w.Finalize();
  double max_pen = 0;
  for (int i = 0; i < 1000; ++i) {
    w.Step();
    ASSERT_TRUE(AllFinite(w));
    ASSERT_FALSE(w.profile.rejected);
    for (const ContactRow& r : w.rows) max_pen = std::max(max_pen, -r.contact.gap);
  }
  const Body& b = w.bodies[ball];
  // at rest vertically (a sphere may roll freely: there is no rolling resistance)
  EXPECT_LT(std::abs(b.velocity.z()), 1e-4);
  EXPECT_GT(w.rows.size(), 3u);
  // the weight is carried: sum of normal forces = m g
  double fn = 0;
  for (const ContactRow& r : w.rows) fn += (r.frame.transpose() * r.r).z();
  EXPECT_NEAR(fn, 0.05 * 9.81, 0.02 * 0.05 * 9.81);
  EXPECT_LT(max_pen, 2e-3);
  // the control points in contact are pushed in
  double umax = 0;
  for (const Vec3& u : b.u) umax = std::max(umax, u.norm());
  EXPECT_GT(umax, 1e-5);
  // lift it off with a kinematic-free teleport: the deformation relaxes
  w.bodies[ball].pose = w.bodies[ball].pose_prev = Pose::Translation(Vec3(0, 0, 0.5));
  w.bodies[ball].velocity.setZero();
  for (int i = 0; i < 200; ++i) w.Step();
  double after = 0;
  for (const Vec3& u : w.bodies[ball].u) after = std::max(after, u.norm());
  EXPECT_LT(after, 1e-3 * umax);
}

// a rigid block on a plane tilted by `angle`; returns the slide along the slope over `seconds`
double InclineSlide(double angle, double mu, double seconds) {
  World w;
  w.params.dt = 1e-3;
  w.params.default_friction = mu;
  w.params.solver.tolerance = 1e-9;
  w.params.solver.max_iterations = 500;
  const Pose plane = Pose::FromAxisAngle(Vec3::UnitY(), angle);
  AddPlane(w, plane);
  ShapeDesc s;
  s.type = EShape::Box;
  s.half_extents = Vec3::Constant(0.02);
  DeformationParams rigid;
  const int block = AddBody(w, s, 6000, 800, 0.1, Pose{plane.R, plane.Apply(Vec3(0, 0, 0.0203))}, rigid);
  w.Finalize();
  // land and settle first
  for (int i = 0; i < 500; ++i) w.Step();
  const Vec3 slope = plane.R.col(0);  // downhill
  const Vec3 start = w.bodies[block].pose.t;
  const double v0 = w.bodies[block].velocity.dot(slope);
  for (int i = 0; i < static_cast<int>(seconds / w.params.dt); ++i) w.Step();
  // the part of the slide due to acceleration over the timed interval
  return std::abs((w.bodies[block].pose.t - start).dot(slope) - v0 * seconds);
}

TEST(World, BlockOnInclineSticksBelowAndSlidesAboveTheFrictionAngle) {
  const double mu = 0.4;
  const double angle = std::atan(mu);
  const double stick = InclineSlide(0.99 * angle, mu, 1.0);
  const double slide = InclineSlide(1.01 * angle, mu, 1.0);
  EXPECT_LT(stick, 1e-6);
  // sliding: s = 1/2 g (sin a - mu cos a) t^2 over the timed second
  const double a = 1.01 * angle;
  const double expected = 0.5 * 9.81 * (std::sin(a) - mu * std::cos(a));
  EXPECT_GT(slide, 0.5 * expected);
  EXPECT_LT(slide, 1.5 * expected);
}

}  // namespace
}  // namespace gs

namespace gs {
namespace {

// two capsules meeting end to end like two phalanges at a joint, overlapping by 4 mm
World JointPair() {
  World w;
  w.params.gravity = Vec3::Zero();
  ShapeDesc cap;
  cap.type = EShape::Capsule;
  cap.radius = 0.008;
  cap.half_length = 0.01;
  DeformationParams rigid;
  const Pose along_x{Eigen::AngleAxisd(0.5 * M_PI, Vec3::UnitY()).toRotationMatrix(), Vec3::Zero()};
  AddBody(w, cap, 400, 50, 0.01, along_x, rigid);
  AddBody(w, cap, 400, 50, 0.01, Pose{along_x.R, Vec3(0.032, 0, 0)}, rigid);
  return w;
}

TEST(World, PairsExcludedBySetCanTouchNeitherCollideNorPush) {
  World touching = JointPair();
  touching.Finalize();
  EXPECT_TRUE(touching.CanTouch(0, 1));
  touching.Step();
  EXPECT_GT(touching.profile.contacts, 0);
  // the overlap pushes them apart
  EXPECT_GT(touching.bodies[1].pose.t.x() - touching.bodies[0].pose.t.x(), 0.032);

  World apart = JointPair();
  apart.Finalize();
  apart.SetCanTouch(1, 0, false);
  EXPECT_FALSE(apart.CanTouch(0, 1));
  for (int i = 0; i < 10; ++i) apart.Step();
  EXPECT_EQ(apart.profile.contacts, 0);
  EXPECT_EQ(apart.profile.work.body_pairs, 0);
  EXPECT_EQ(apart.rejected_steps, 0);
  EXPECT_EQ(apart.bodies[1].pose.t.x() - apart.bodies[0].pose.t.x(), 0.032);
  // readmitted, and kept through a Finalize with the same bodies
  apart.SetCanTouch(0, 1, true);
  apart.SetCanTouch(0, 1, false);
  apart.Finalize();
  EXPECT_FALSE(apart.CanTouch(1, 0));
  apart.SetCanTouch(0, 1, true);
  apart.Step();
  EXPECT_GT(apart.profile.contacts, 0);
}

}  // namespace
}  // namespace gs
