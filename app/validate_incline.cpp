// The incline validation: a block on a tilted plane sticks below atan(mu) and
// slides above it with the analytic acceleration.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "app/code_scenes.h"
#include "app/paths.h"
#include "app/scene_file.h"
#include "app/validation_util.h"
#include "core/world.h"

namespace gs::app {
namespace {

struct InclineRun {
  double slide = 0.0;  // distance along the slope over the timed second (m)
  double accel = 0.0;  // fitted acceleration along the slope (m/s^2)
  bool finite = true;
};

InclineRun RunIncline(double angle, double mu, bool quick) {
  World w;
  w.params.dt = 1e-3;
  w.params.default_friction = mu;
  w.params.solver.tolerance = 1e-10;
  w.params.solver.max_iterations = 1000;
  const Pose plane = Pose::FromAxisAngle(Vec3::UnitY(), angle);
  AddBody(w, PlaneSpec("plane", plane));
  BodySpec b;
  b.name = "block";
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3::Constant(0.02);
  b.geometry.points = quick ? 3000 : 6000;
  b.geometry.control_points = quick ? 400 : 800;
  b.mass = 0.1;
  // a little above the plane (sharp edges' MLS surface bulges by a fraction of the spacing)
  b.pose = Pose{plane.R, plane.Apply(Vec3(0, 0, 0.0203))};
  const int block = AddBody(w, b);
  w.Finalize();
  // let it land and the landing slip die out, then time one second
  for (int i = 0; i < 500; ++i) w.Step();
  const Vec3 slope = plane.R.col(0);  // downhill for a rotation about +y
  const Vec3 x0 = w.bodies[block].pose.t;
  const double v0 = w.bodies[block].velocity.dot(slope);
  InclineRun r;
  const int steps = 1000;
  for (int i = 0; i < steps; ++i) {
    w.Step();
    r.finite &= w.bodies[block].pose.t.allFinite();
  }
  const double s = (w.bodies[block].pose.t - x0).dot(slope);
  r.slide = std::abs(s);
  const double t = steps * w.params.dt;
  r.accel = 2.0 * (s - v0 * t) / (t * t);
  return r;
}

}  // namespace

std::vector<ValidationResult> ValidateIncline(const ValidationOptions& opt) {
  const double mu = 0.4;
  const double critical = std::atan(mu);
  std::vector<ValidationResult> out;
  const InclineRun stick = RunIncline(0.99 * critical, mu, opt.quick);
  char d[256];
  std::snprintf(d, sizeof d, "tilt 0.99 atan(mu), mu %.2f: slid %.3g m in 1 s (limit 1e-6 m)", mu, stick.slide);
  out.push_back(Result("incline_stick", stick.finite ? stick.slide : NAN, 1e-6, "m", d));
  const double a = 1.01 * critical;
  const double expected = kG * (std::sin(a) - mu * std::cos(a));
  const InclineRun slide = RunIncline(a, mu, opt.quick);
  const double rel = std::abs(slide.accel - expected) / expected;
  std::snprintf(d, sizeof d, "tilt 1.01 atan(mu): acceleration %.4f m/s^2, expected g(sin a - mu cos a) = %.4f",
                slide.accel, expected);
  out.push_back(Result("incline_slide", slide.finite ? rel : NAN, 0.05, "relative", d));
  return out;
}


}  // namespace gs::app
