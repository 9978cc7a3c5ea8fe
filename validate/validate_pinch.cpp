// The pinch validation: three fingertips squeeze a prism (or a cylinder) with P
// each, lift it at a friction well above mu* = m g / (3 P), stop, and the friction
// is set to the case's: at 1.005 mu* the object stays (creep), at 0.995 mu* it
// falls, at 0.98 mu* it slides down at g (1 - mu / mu*). Every case runs with soft
// and rigid fingertips, at two control-point densities, in both contact modes
// (two-pass: the object's control points touch the fingertips too; one-pass: only
// the fingertips' points touch the object): no mode may add grip.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <Eigen/Dense>

#include "scene/code_scenes.h"
#include "validate/validation_util.h"
#include "core/world.h"
#include "session/console.h"

namespace gs::app {

namespace {

struct PinchCase {
  bool cylinder = false;
  bool rigid = false;
  bool dense = false;
  bool two_pass = true;
  std::string Suffix() const {
    return std::string(cylinder ? "cylinder" : "prism") + (rigid ? "_rigid" : "_soft") + (dense ? "_dense" : "_sparse") +
           (two_pass ? "_two-pass" : "_one-pass");
  }
  const char* Mode() const { return two_pass ? "two-pass" : "one-pass"; }
};

struct PinchRun {
  bool finite = true;
  double creep = 0.0;   // |d(z - z_tips)/dt| over the last half of the hold (m/s)
  double sank = 0.0;    // how far the object sank relative to the fingertips during the hold (m)
  double accel = 0.0;   // downward acceleration relative to the fingertips, fitted over the hold (m/s^2)
};

constexpr double kMass = 0.1, kSqueeze = 1.0;
constexpr double kLiftMu = 1.2;      // friction (x mu*) while lifting: ample margin for the lift's acceleration
constexpr double kSqueezeTime = 0.2, kLift = 0.02;
constexpr double kFitSkip = 0.05;    // s after the switch before the acceleration fit (the forces settle)

double MuStar() { return kMass * kG / (3.0 * kSqueeze); }

// least-squares z = c0 + c1 t + c2 t^2 over the samples: the acceleration 2 c2
double FitAcceleration(const std::vector<double>& t, const std::vector<double>& z) {
  if (t.size() < 3) return NAN;
  Eigen::MatrixXd A(t.size(), 3);
  Eigen::VectorXd b(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    A(i, 0) = 1.0;
    A(i, 1) = t[i];
    A(i, 2) = t[i] * t[i];
    b(i) = z[i];
  }
  const Eigen::Vector3d c = A.colPivHouseholderQr().solve(b);
  return 2.0 * c(2);
}

// squeeze on the table, lift kLift over lift_time at kLiftMu mu*, then hold the
// fingertips still for hold_time with friction mu_factor mu*
PinchRun RunPinch(const PinchCase& pc, double mu_factor, double lift_time, double hold_time) {
  World w;
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-9;
  w.params.solver.max_iterations = 300;
  w.params.default_friction = 0.5;  // the object on the table
  PinchRigSpec spec;
  spec.prism_mass = kMass;
  spec.squeeze_force = kSqueeze;
  spec.prism_points = pc.dense ? 16000 : 8000;
  spec.prism_control_points = pc.dense ? 2000 : 1000;
  spec.cylinder = pc.cylinder;
  spec.two_pass = pc.two_pass;
  spec.rigid_tips = pc.rigid;
  const PinchRig rig = AddPinchRig(w, spec);
  PinchRun r;
  if (!rig.ok()) {
    r.finite = false;
    return r;
  }
  w.Finalize();
  const int obj = rig.prism;
  for (int k : rig.tips) w.SetFriction(k, obj, kLiftMu * MuStar());
  const double t_switch = kSqueezeTime + lift_time;
  const int steps = static_cast<int>(std::lround((t_switch + hold_time) / w.params.dt));
  std::vector<double> ts, zs;
  double z_switch = 0.0, z_half = 0.0, t_half = 0.0;
  bool switched = false, halved = false;
  for (int i = 0; i < steps; ++i) {
    const double t = w.time + w.params.dt;
    // a quintic smoothstep lift: its acceleration peaks at 5.77 kLift / lift_time^2
    const double s = std::clamp((t - kSqueezeTime) / lift_time, 0.0, 1.0);
    const double rise = kLift * s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
    for (size_t k = 0; k < rig.tips.size(); ++k) {
      w.bodies[rig.tips[k]].drive.target = rig.tip_start[k];
      w.bodies[rig.tips[k]].drive.target.t.z() += rise;
    }
    w.Step();
    if (StopRequested()) break;  // Ctrl-C: the case ends here, reported as interrupted
    double tip_z = 0.0;
    for (int k : rig.tips) tip_z += w.bodies[k].pose.t.z() / 3.0;
    const double rel = w.bodies[obj].pose.t.z() - tip_z;
    r.finite &= std::isfinite(rel);
    if (!switched && w.time >= t_switch - 1e-9) {
      for (int k : rig.tips) w.SetFriction(k, obj, mu_factor * MuStar());
      switched = true;
      z_switch = rel;
    }
    if (switched && !halved && w.time >= t_switch + 0.5 * hold_time - 1e-9) {
      halved = true;
      z_half = rel;
      t_half = w.time;
    }
    if (switched && w.time >= t_switch + kFitSkip) {
      ts.push_back(w.time - t_switch);
      zs.push_back(rel);
    }
  }
  const double rel_end = zs.empty() ? NAN : zs.back();
  r.sank = z_switch - rel_end;
  r.creep = std::abs(rel_end - z_half) / std::max(1e-9, w.time - t_half);
  r.accel = -FitAcceleration(ts, zs);
  return r;
}

void AddCase(const PinchCase& pc, bool quick, std::vector<ValidationResult>* out) {
  char d[320];
  const std::string sfx = pc.Suffix();
  const double lift_time = quick ? 0.5 : 1.0;
  // held: after the switch, the object must not move (creep over the hold's second half)
  const PinchRun hold = RunPinch(pc, 1.005, lift_time, quick ? 0.6 : 2.0);
  const bool held = hold.finite && hold.sank < 0.25 * kLift;
  std::snprintf(d, sizeof d, "mu = 1.005 mu*: %s, sank %.3g mm, creep %.3g m/s over the hold's second half (limit 1e-6)",
                held ? "held" : "DROPPED", 1e3 * hold.sank, hold.creep);
  out->push_back(Result("pinch_hold_" + sfx, held ? hold.creep : INFINITY, 1e-6, "m/s", d, pc.Mode()));
  // falls: sinks at 0.005 g (8.8 mm in 0.6 s): at least 1 mm
  const PinchRun fall = RunPinch(pc, 0.995, lift_time, 0.6);
  const bool fell = fall.finite && fall.sank > 1e-3;
  std::snprintf(d, sizeof d, "mu = 0.995 mu*: %s, sank %.3g mm in 0.6 s (at least 1 mm; %.3g expected)",
                fell ? "fell" : "HELD", 1e3 * fall.sank, 1e3 * 0.5 * 0.005 * kG * 0.36);
  // error: 0 when it fell, 1 when it was (wrongly) held
  out->push_back(Result("pinch_fall_" + sfx, fell ? 0.0 : 1.0, 0.0, "held (0/1)", d, pc.Mode()));
  // slips at g (1 - mu / mu*) (16 mm in 0.4 s, within the 20 mm lift)
  const PinchRun slip = RunPinch(pc, 0.98, lift_time, 0.4);
  const double expected = kG * (1.0 - 0.98);
  const double err = slip.finite ? std::abs(slip.accel - expected) / expected : INFINITY;
  std::snprintf(d, sizeof d, "mu = 0.98 mu*: slides at %.4g m/s^2, g (1 - mu/mu*) = %.4g (relative error, limit 1%%)",
                slip.accel, expected);
  out->push_back(Result("pinch_slip_" + sfx, err, 0.01, "relative", d, pc.Mode()));
}

}  // namespace

std::vector<ValidationResult> ValidatePinch(const ValidationOptions& opt) {
  std::vector<ValidationResult> out;
  if (opt.quick) {
    // the default mode on both shapes, and one-pass on the prism: soft, sparse
    for (const PinchCase& pc : {PinchCase{false, false, false, true}, PinchCase{true, false, false, true},
                                PinchCase{false, false, false, false}})
      if (!StopRequested()) AddCase(pc, true, &out);
    return out;
  }
  for (int mask = 0; mask < 16 && !StopRequested(); ++mask)
    AddCase(PinchCase{(mask & 1) != 0, (mask & 2) != 0, (mask & 4) != 0, (mask & 8) == 0}, false, &out);
  return out;
}

}  // namespace gs::app
