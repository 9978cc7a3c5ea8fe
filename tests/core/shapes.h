// Shapes shared by the core geometry and collision tests: the paper's fingertip
// (an 8 x 8 x 11 mm ellipsoid) and cubes (the paper's box is a 6 cm one).
#pragma once

#include "core/sampling.h"

namespace gs::test {

inline ShapeDesc FingertipEllipsoid() {
  ShapeDesc s;
  s.type = EShape::Ellipsoid;
  s.semi_axes = Vec3(0.008, 0.008, 0.011);
  return s;
}

inline ShapeDesc CubeShape(double edge) {
  ShapeDesc s;
  s.type = EShape::Box;
  s.half_extents = Vec3::Constant(edge / 2);
  return s;
}

}  // namespace gs::test
