// Bodies shared by the core tests: a fixed soft slab (6 cm x 6 cm x 2 cm, 6,000
// points, 800 control points) and a free soft ball (1 cm radius, 1,500 points,
// 200 control points, 50 g), both with the Gaussian model (eq. 13-14); a free
// rigid cube of 1,500 points and 200 control points (50 g); the plane z = 0.
// Each test places, drives or softens them itself.
#pragma once

#include "core/world.h"

namespace gs::test {

inline BodySpec SoftSlab(const char* name) {
  BodySpec slab;
  slab.name = name;
  slab.shape.type = EShape::Box;
  slab.shape.half_extents = Vec3(0.03, 0.03, 0.01);
  slab.geometry.points = 6000;
  slab.geometry.control_points = 800;
  slab.motion = EMotion::Fixed;
  slab.deformation.model = EDeformation::Gaussian;
  slab.deformation.stiffness = 20000;
  slab.deformation.damping = 20;
  slab.deformation.influence_radius = 0.003;
  return slab;
}

inline BodySpec SoftBall() {
  BodySpec ball;
  ball.name = "ball";
  ball.shape.type = EShape::Sphere;
  ball.shape.radius = 0.01;
  ball.geometry.points = 1500;
  ball.geometry.control_points = 200;
  ball.mass = 0.05;
  ball.deformation.model = EDeformation::Gaussian;
  ball.deformation.stiffness = 500;
  ball.deformation.damping = 1;
  ball.deformation.influence_radius = 0.003;
  return ball;
}

/// The soft ball at `at`; rigid (no deformation) when !deformable.
inline BodySpec SoftBall(const Vec3& at, bool deformable = true) {
  BodySpec ball = SoftBall();
  ball.pose = Pose::Translation(at);
  if (!deformable) ball.deformation = BodySpec().deformation;
  return ball;
}

/// A free rigid cube of half side `half` centred at `at` (50 g).
inline BodySpec SmallBox(const char* name, const Vec3& at, double half) {
  BodySpec b;
  b.name = name;
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3::Constant(half);
  b.geometry.points = 1500;
  b.geometry.control_points = 200;
  b.mass = 0.05;
  b.pose = Pose::Translation(at);
  return b;
}

/// The fixed analytic plane z = 0 named "plane"; returns its body index.
inline int AddPlane(World& w) {
  BodySpec plane;
  plane.name = "plane";
  plane.is_plane = true;
  return AddBody(w, plane);
}

}  // namespace gs::test
