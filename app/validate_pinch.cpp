// The pinch validation: three fingertips hold a prism above mu* = m g / (3 P)
// and let it fall below.
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

// ---- pinch hold ------------------------------------------------------------

namespace {

struct PinchRun {
  bool held = false;
  double creep = 0.0;  // |dz/dt| over the last second of the hold (m/s)
  double drop = 0.0;   // how far the prism sank relative to the fingertips (m)
  bool finite = true;
};

PinchRun RunPinch(double mu_factor, bool quick) {
  const double m = 0.1, P = 1.0;
  const double mu_star = m * kG / (3.0 * P);
  World w;
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-9;
  w.params.solver.max_iterations = 300;
  w.params.default_friction = 0.5;
  PinchRigSpec spec;
  spec.prism_mass = m;
  spec.squeeze_force = P;
  spec.prism_points = quick ? 8000 : 12000;
  spec.prism_control_points = quick ? 1000 : 1600;
  const PinchRig rig = AddPinchRig(w, spec);
  PinchRun r;
  if (!rig.ok()) {
    r.finite = false;
    return r;
  }
  const int prism = rig.prism;
  const std::vector<int>& tips = rig.tips;
  w.Finalize();
  for (int k : tips) w.SetFriction(k, prism, mu_factor * mu_star);
  // The lift must not ask friction for more than the margin it has: at mu = 1.005 mu*
  // the three contacts can carry 1.005 m g, so the prism can be accelerated upward by
  // at most 0.005 g = 0.049 m/s^2 before it slips (an abrupt lift at constant speed
  // needs an infinite acceleration at its start, and the prism slides down the
  // fingertips by v^2 / (2 * 0.049 m/s^2) before it catches up: 37 mm at 6 cm/s).
  // A quintic smoothstep over lift_time peaks at 5.77 lift / lift_time^2: 0.014 m/s^2
  // (1 cm in 2 s; quick: 0.029 m/s^2, 5 mm in 1 s), well inside that margin.
  const double lift = quick ? 0.005 : 0.01, lift_time = quick ? 1.0 : 2.0, hold = quick ? 1.0 : 10.0;
  const int steps = static_cast<int>((0.2 + lift_time + hold) / w.params.dt);
  const std::vector<Pose>& start = rig.tip_start;
  double z_mark = 0.0;
  for (int i = 0; i < steps; ++i) {
    const double t = w.time + w.params.dt;
    // squeeze 0.2 s on the table, lift over lift_time, hold
    const double s = std::clamp((t - 0.2) / lift_time, 0.0, 1.0);
    const double rise = lift * s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
    for (size_t k = 0; k < tips.size(); ++k) {
      w.bodies[tips[k]].drive.target = start[k];
      w.bodies[tips[k]].drive.target.t.z() += rise;
    }
    w.Step();
    r.finite &= w.bodies[prism].pose.t.allFinite();
    if (i == steps - static_cast<int>(1.0 / w.params.dt)) z_mark = w.bodies[prism].pose.t.z();
  }
  double tip_z = 0;
  for (int k : tips) tip_z += w.bodies[k].pose.t.z() / 3.0;
  const double z = w.bodies[prism].pose.t.z();
  r.creep = std::abs(z - z_mark) / 1.0;
  r.drop = tip_z - z;
  r.held = r.finite && r.drop < 0.25 * lift && z > 0.03 + 0.5 * lift;
  return r;
}

}  // namespace

std::vector<ValidationResult> ValidatePinch(const ValidationOptions& opt) {
  std::vector<ValidationResult> out;
  char d[256];
  const PinchRun hold = RunPinch(1.005, opt.quick);
  std::snprintf(d, sizeof d, "mu = 1.005 mu*: %s, %.3g mm below the fingertips, creep %.3g m/s over the last second (limit 1e-6)",
                hold.held ? "held" : "DROPPED", 1e3 * hold.drop, hold.creep);
  out.push_back(Result("pinch_hold", hold.held ? hold.creep : INFINITY, 1e-6, "m/s", d));
  const PinchRun fall = RunPinch(0.995, opt.quick);
  std::snprintf(d, sizeof d, "mu = 0.995 mu*: %s, sank %.3g m below the fingertips", fall.held ? "HELD" : "fell",
                fall.drop);
  // error: 0 when it fell, 1 when it was (wrongly) held
  out.push_back(Result("pinch_fall", fall.finite && !fall.held ? 0.0 : 1.0, 0.0, "held (0/1)", d));
  return out;
}


}  // namespace gs::app
