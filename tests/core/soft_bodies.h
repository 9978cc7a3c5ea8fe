// Bodies shared by the core tests of deformable contact: a fixed soft slab
// (6 cm x 6 cm x 2 cm, 6,000 points, 800 control points) and a free soft ball
// (1 cm radius, 1,500 points, 200 control points, 50 g), both with the
// Gaussian model (eq. 13-14). Each test places and drives them itself.
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

}  // namespace gs::test
