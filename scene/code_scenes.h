// Scenes built in code rather than read from YAML, shared by the validation
// cases (validation.cpp) and the benchmarks that sweep them (bench_tradeoff.cpp,
// bench_scaling.cpp): one definition each, so a benchmark measures the scene the
// validation checks.
#pragma once

#include <string>
#include <vector>

#include "core/world.h"

namespace gs::app {

/// A fixed infinite plane through pose.t with normal pose.R z.
BodySpec PlaneSpec(const std::string& name, const Pose& pose);

/// A closed hexagonal prism about z, centred on the origin: vertices at
/// 30 + k 60 degrees, so its side faces' normals point at k 60 degrees.
TriangleMesh HexagonalPrism(double circumradius, double height);

/// The three-finger pinch: a hexagonal prism (circumradius 2 cm, height 6 cm; or a
/// cylinder of radius 1.73 cm, the prism's apothem)
/// standing on the table at the origin, and three Gaussian fingertips (radius
/// 8 mm, 2,400 points, 320 control points) on its side faces 120 degrees apart,
/// each driven toward the prism's axis with the constant force `squeeze_force`
/// and held stiffly across and vertically.
struct PinchRigSpec {
  double prism_mass = 0.1;      ///< kg
  double squeeze_force = 1.0;   ///< N per fingertip
  int prism_points = 8000;
  int prism_control_points = 1000;
  bool cylinder = false;        ///< a cylinder of the prism's apothem in its place
  bool two_pass = false;        ///< the prism's control points touch the fingertips too (default: one-pass)
  bool rigid_tips = false;      ///< fingertips without deformation
};
struct PinchRig {
  int table = -1, prism = -1;
  std::vector<int> tips;
  std::vector<Pose> tip_start;  ///< each fingertip's drive target at rest
  bool ok() const;
};
/// Adds the table, the prism and the fingertips to `w` (not finalized); any
/// body that fails to build leaves its id at -1 and `error` (when given) set.
PinchRig AddPinchRig(World& w, const PinchRigSpec& spec, EGeometryError* error = nullptr);

}  // namespace gs::app
