// The Hertz validation: a Boussinesq sphere pressed on a plane against Hertz's
// contact theory.
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

// ---- Hertz -----------------------------------------------------------------

std::vector<ValidationResult> ValidateHertz(const ValidationOptions& opt) {
  const double R = 0.02, E = 1e5, nu = 0.45;
  const std::vector<double> loads = opt.quick ? std::vector<double>{0.5, 2.0} : std::vector<double>{0.25, 0.5, 1.0, 2.0};
  World w;
  w.params.dt = 0.01;  // quasi-static: any step is stable
  w.params.gravity.setZero();
  w.params.solver.tolerance = 1e-8;
  w.params.solver.max_iterations = 2000;
  w.params.default_friction = 0.0;
  AddBody(w, PlaneSpec("table", Pose{}));
  BodySpec s;
  s.name = "sphere";
  s.shape.type = EShape::Sphere;
  s.shape.radius = R;
  s.geometry.points = opt.quick ? 12000 : 20000;
  s.geometry.control_points = opt.quick ? 3000 : 5000;
  s.dynamics = EDynamics::QuasiStatic;
  s.mass = 0.1;
  s.linear_damping = 100.0;
  s.angular_damping = 1.0;
  s.deformation.model = EDeformation::Boussinesq;
  s.deformation.young_modulus = E;
  s.deformation.poisson_ratio = nu;
  s.deformation.influence_radius = 0.016;
  s.drive.enabled = true;
  s.drive.angular_stiffness = Vec3::Constant(1.0);
  s.pose = Pose::Translation(Vec3(0, 0, R));
  s.drive.target = s.pose;
  const int sphere = AddBody(w, s);
  w.Finalize();
  // the height at which the lowest control point touches the plane
  double lowest = 0;
  for (const Vec3& c : w.bodies[sphere].geometry.tree.control_points()) lowest = std::min(lowest, c.z());
  w.bodies[sphere].pose.t.z() = -lowest;
  w.bodies[sphere].pose_prev = w.bodies[sphere].pose;
  std::vector<double> ld, lf, radius_err;
  char d[512];
  std::string detail;
  for (double F : loads) {
    w.bodies[sphere].drive.force = Vec3(0, 0, -F);
    for (int i = 0; i < 300; ++i) w.Step();
    const double depth = -lowest - w.bodies[sphere].pose.t.z();
    // Contact radius from the force-weighted second moment of the contact forces about
    // the sphere's axis. For Hertz's pressure p = p0 sqrt(1 - r^2/a^2),
    //   <r^2> = int p r^2 dA / int p dA = a^2 int_0^1 s sqrt(1-s) ds / int_0^1 sqrt(1-s) ds
    //         = a^2 (4/15) / (2/3) = 2/5 a^2        (s = r^2/a^2),
    // so a = sqrt(5/2 <r^2>). Why this and not the contact set's extent: each contact is a
    // control point carrying the pressure over its own patch (the points are spread
    // evenly, one patch per point), so the force-weighted sum is a quadrature of the two
    // integrals. The pressure falls to zero at the rim as a square root, so rim points
    // weigh little and whether one is in or out of the contact moves the estimate by a
    // small fraction of a spacing. The contact set itself also holds points that carry no
    // force (every gap under delta_eps enters it), and its area or largest radius is
    // quantised by the spacing (1 mm here against a = 3-6 mm): those estimators are
    // biased by the sampling, not by the physics.
    const Vec3 c = w.bodies[sphere].pose.t;
    double m0 = 0, m2 = 0;
    for (const ContactRow& r : w.rows) {
      const double f = std::max(0.0, r.r[0]);
      m0 += f;
      m2 += f * (r.world_point - Vec3(c.x(), c.y(), 0)).head<2>().squaredNorm();
    }
    const double a = m0 > 0 ? std::sqrt(2.5 * m2 / m0) : 0.0;
    const double a_hertz = std::sqrt(R * depth);
    radius_err.push_back(std::abs(a - a_hertz) / a_hertz);
    ld.push_back(std::log(depth));
    lf.push_back(std::log(F));
    // Hertz's indentation of an elastic sphere on a rigid plane: F = 4/3 E* sqrt(R) d^1.5,
    // E* = E / (1 - nu^2) (for information: the pass criteria are the exponent and a)
    const double e_star = E / (1.0 - nu * nu);
    const double d_hertz = std::pow(3.0 * F / (4.0 * e_star * std::sqrt(R)), 2.0 / 3.0);
    std::snprintf(d, sizeof d, "F %.2f N: d %.3f mm (Hertz %.3f), a %.2f mm (sqrt(Rd) %.2f mm); ", F, 1e3 * depth,
                  1e3 * d_hertz, 1e3 * a, 1e3 * a_hertz);
    detail += d;
  }
  // least-squares slope of log F against log d
  const int n = static_cast<int>(ld.size());
  double mx = 0, my = 0;
  for (int i = 0; i < n; ++i) {
    mx += ld[i] / n;
    my += lf[i] / n;
  }
  double sxy = 0, sxx = 0;
  for (int i = 0; i < n; ++i) {
    sxy += (ld[i] - mx) * (lf[i] - my);
    sxx += (ld[i] - mx) * (ld[i] - mx);
  }
  const double exponent = sxx > 0 ? sxy / sxx : NAN;
  std::vector<ValidationResult> out;
  std::snprintf(d, sizeof d, "fitted exponent %.3f (Hertz 1.5); ", exponent);
  out.push_back(Result("hertz_exponent", std::abs(exponent - 1.5), 0.1, "absolute", d + detail));
  const double worst = *std::max_element(radius_err.begin(), radius_err.end());
  out.push_back(Result("hertz_radius", worst, 0.10, "relative",
                       "contact radius (from the force-weighted second moment) against sqrt(R d): " + detail));
  return out;
}

}  // namespace gs::app
