// `graspsim bench tradeoff [--json] [--quick] [--plot DIR]`: run time against
// error for every knob (bench/tradeoff.h). The scenes are those of `graspsim
// validate` (validate/validation.cpp: Hertz sphere, three-finger pinch) rebuilt here
// with the knob free, plus MLS accuracy (MeasureMlsAccuracy, bench/bench.h), the
// FCLIB-form problems of `bench solver`, and a tumbling box for the time step.
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench/bench.h"
#include "scene/code_scenes.h"
#include "scene/paths.h"
#include "scene/scene_file.h"
#include "bench/tradeoff.h"
#include "core/fc_problem.h"
#include "core/world.h"
#include "plot/gnuplot.h"
#include "scene/exit_code.h"
#include "session/console.h"

namespace gs::app {
namespace {

constexpr double kG = 9.81;

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double Now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

struct Emitter {
  std::vector<TradeoffRow>* rows;
  void (*progress)(const TradeoffRow&);
  void operator()(TradeoffRow r) {
    if (progress) progress(r);
    rows->push_back(std::move(r));
    if (StopRequested()) throw Stopped{};  // Ctrl-C: the sweep ends at this row, the rows so far are kept
  }
  struct Stopped {};
};

// ---- surface points: MLS error on a sphere / step time of a ball resting on it ----

double BallOnSphereStepMs(int points, int settle, int timed) {
  auto w = std::make_unique<World>();
  AddBody(*w, PlaneSpec("floor", Pose::Translation(Vec3(0, 0, -0.05))));
  BodySpec big;
  big.name = "sphere";
  big.shape.type = EShape::Sphere;
  big.shape.radius = 0.03;
  big.geometry.points = points;
  big.geometry.control_points = 400;
  big.motion = EMotion::Fixed;
  big.mass = 1.0;
  AddBody(*w, big);
  BodySpec ball;
  ball.name = "ball";
  ball.shape.type = EShape::Sphere;
  ball.shape.radius = 0.01;
  ball.geometry.points = 2000;
  ball.geometry.control_points = 300;
  ball.mass = 0.05;
  ball.deformation.model = EDeformation::Gaussian;
  ball.deformation.stiffness = 500;
  ball.deformation.damping = 0.5;
  ball.deformation.influence_radius = 0.002;
  ball.pose = Pose::Translation(Vec3(0, 0, 0.0401));
  AddBody(*w, ball);
  w->Finalize();
  for (int i = 0; i < settle; ++i) w->Step();
  std::vector<double> ms;
  for (int i = 0; i < timed; ++i) {
    w->Step();
    ms.push_back(1e3 * w->profile.total);
  }
  return Median(ms);
}

void SweepSurfacePoints(const TradeoffOptions& opt, Emitter& emit) {
  const std::vector<int> counts =
      opt.quick ? std::vector<int>{1000, 10000} : std::vector<int>{1000, 3000, 10000, 30000, 100000};
  ShapeDesc sphere;
  sphere.type = EShape::Sphere;
  sphere.radius = 0.03;
  for (int n : counts) {
    const MlsAccuracy a = MeasureMlsAccuracy(sphere, n, 1.5, true, opt.quick ? 500 : 2000, 3);
    TradeoffRow r;
    r.knob = "surface_points";
    r.value = n;
    r.error_name = "mls_projection";
    r.error = a.median_err * a.spacing;
    r.error_unit = "m";
    r.time_ms = BallOnSphereStepMs(n, opt.quick ? 20 : 50, opt.quick ? 20 : 100);
    r.time_what = "step, 1 cm ball resting on a 3 cm sphere of N points";
    char d[200];
    std::snprintf(d, sizeof d, "spacing %.3g mm, median %.3g / max %.3g spacings off the sphere, %d failed",
                  1e3 * a.spacing, a.median_err, a.max_err, a.failed);
    r.detail = d;
    emit(r);
  }
}

// ---- kernel bandwidth: MLS error / time per projection ----

void SweepBandwidth(const TradeoffOptions& opt, Emitter& emit) {
  const std::vector<double> factors =
      opt.quick ? std::vector<double>{1.0, 2.0} : std::vector<double>{1.0, 1.25, 1.5, 2.0, 3.0, 4.0};
  ShapeDesc sphere;
  sphere.type = EShape::Sphere;
  sphere.radius = 0.02;
  for (int quadric = 0; quadric < 2; ++quadric)
    for (double f : factors) {
      const MlsAccuracy a = MeasureMlsAccuracy(sphere, 2400, f, quadric != 0, opt.quick ? 500 : 4000, 5);
      TradeoffRow r;
      r.knob = "bandwidth";
      r.value = f;
      r.variant = quadric ? "quadric" : "plane";
      r.error_name = "mls_projection";
      r.error = a.median_err * a.spacing;
      r.error_unit = "m";
      r.time_ms = 1e-6 * a.ns_per_projection;
      r.time_what = "one MLS projection (h = value x spacing), 2 cm sphere of 2,400 points";
      char d[200];
      std::snprintf(d, sizeof d, "median %.3g / max %.3g spacings, normal median %.3g deg, %d failed", a.median_err,
                    a.max_err, a.median_deg, a.failed);
      r.detail = d;
      emit(r);
    }
}

// ---- control points: Hertz (validation.cpp's scene, control points free) ----

struct HertzRun {
  double radius_err = NAN, exponent_err = NAN, step_ms = NAN;
};

HertzRun RunHertz(int control_points, bool quick) {
  const double R = 0.02, E = 1e5, nu = 0.45;
  const std::vector<double> loads = quick ? std::vector<double>{0.5, 2.0} : std::vector<double>{0.25, 0.5, 1.0, 2.0};
  auto w = std::make_unique<World>();
  w->params.dt = 0.01;
  w->params.gravity.setZero();
  w->params.solver.tolerance = 1e-8;
  w->params.solver.max_iterations = 2000;
  w->params.default_friction = 0.0;
  AddBody(*w, PlaneSpec("table", Pose{}));
  BodySpec s;
  s.name = "sphere";
  s.shape.type = EShape::Sphere;
  s.shape.radius = R;
  s.geometry.points = 4 * control_points;
  s.geometry.control_points = control_points;
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
  const int sphere = AddBody(*w, s);
  HertzRun out;
  if (sphere < 0) return out;
  w->Finalize();
  double lowest = 0;
  for (const Vec3& c : w->bodies[sphere].geometry.tree.control_points()) lowest = std::min(lowest, c.z());
  w->bodies[sphere].pose.t.z() = -lowest;
  w->bodies[sphere].pose_prev = w->bodies[sphere].pose;
  std::vector<double> ld, lf, ms;
  double worst = 0;
  for (double F : loads) {
    w->bodies[sphere].drive.force = Vec3(0, 0, -F);
    for (int i = 0; i < 300; ++i) {
      w->Step();
      ms.push_back(1e3 * w->profile.total);
    }
    const double depth = -lowest - w->bodies[sphere].pose.t.z();
    const Vec3 c = w->bodies[sphere].pose.t;
    double m0 = 0, m2 = 0;
    for (const ContactRow& r : w->rows) {
      const double f = std::max(0.0, r.r[0]);
      m0 += f;
      m2 += f * (r.world_point - Vec3(c.x(), c.y(), 0)).head<2>().squaredNorm();
    }
    if (!(depth > 0) || m0 <= 0) return out;
    const double a = std::sqrt(2.5 * m2 / m0);  // Hertz pressure: <r^2> = 2/5 a^2
    worst = std::max(worst, std::abs(a - std::sqrt(R * depth)) / std::sqrt(R * depth));
    ld.push_back(std::log(depth));
    lf.push_back(std::log(F));
  }
  const int n = static_cast<int>(ld.size());
  double mx = 0, my = 0, sxy = 0, sxx = 0;
  for (int i = 0; i < n; ++i) mx += ld[i] / n, my += lf[i] / n;
  for (int i = 0; i < n; ++i) sxy += (ld[i] - mx) * (lf[i] - my), sxx += (ld[i] - mx) * (ld[i] - mx);
  out.radius_err = worst;
  out.exponent_err = sxx > 0 ? std::abs(sxy / sxx - 1.5) : NAN;
  out.step_ms = Median(ms);
  return out;
}

void SweepControlPoints(const TradeoffOptions& opt, Emitter& emit) {
  const std::vector<int> counts = opt.quick ? std::vector<int>{500, 1500} : std::vector<int>{750, 1500, 3000, 5000};
  for (int n : counts) {
    const HertzRun h = RunHertz(n, opt.quick);
    for (int e = 0; e < 2; ++e) {
      TradeoffRow r;
      r.knob = "control_points";
      r.value = n;
      r.error_name = e == 0 ? "hertz_radius" : "hertz_exponent";
      r.error = e == 0 ? h.radius_err : h.exponent_err;
      r.error_unit = e == 0 ? "relative" : "absolute";
      r.time_ms = h.step_ms;
      r.time_what = "step, Boussinesq sphere (R 2 cm, 4 points per control point) pressed on a plane";
      r.detail = e == 0 ? "contact radius from the force-weighted second moment against sqrt(R d), worst load"
                        : "fitted exponent of F against d, minus Hertz's 1.5";
      emit(r);
    }
  }
}

// ---- Gauss-Seidel tolerance and sweep cap: residual on fixed problems ----

struct NamedProblem {
  std::string name;
  FcProblem p;
};

bool PaperGraspProblem(FcProblem* p) {
  auto built = std::make_unique<BuiltScene>();
  std::string error;
  if (!LoadAndBuildScene(ResolveResource("config/paper_box_grasp.yaml"), built.get(), &error)) return false;
  World& w = built->world;
  while (w.time < 1.0 - 0.5 * w.params.dt) {  // into the hold: the deepest grasp
    built->script.Apply(w, w.time + w.params.dt);
    w.Step();
  }
  AssembleContactProblem(w, p);
  return p->contacts > 0;
}

std::vector<NamedProblem> SolverProblems(bool quick) {
  std::vector<NamedProblem> v;
  const int n = quick ? 50 : 150;
  v.push_back({"random_rigid_" + std::to_string(n), RandomRigidProblem(n, 4, 7)});
  if (!quick) {
    NamedProblem g{"paper_grasp_t1.0", {}};
    if (PaperGraspProblem(&g.p)) v.push_back(std::move(g));
  }
  return v;
}

// returns false when the solve stopped at the sweep cap
bool SolveRow(const NamedProblem& pr, const NsgsParams& np, const char* knob, double value, bool quick, Emitter& emit) {
  FcSolveParams params;
  params.nsgs = np;
  std::vector<double> ms;
  Eigen::VectorXd r;
  FcSolveResult res;
  // repetitions for about 0.5 s (quick: 0.1 s) of solving, 1 to 7
  int reps = 1;
  for (int k = 0; k < reps; ++k) {
    r.setZero(3 * pr.p.contacts);
    res = SolveFcProblem(pr.p, params, &r);
    ms.push_back(1e3 * res.seconds);
    if (k == 0) reps = std::clamp(static_cast<int>((quick ? 0.1 : 0.5) / std::max(res.seconds, 1e-9)), 1, 7);
  }
  TradeoffRow row;
  row.knob = knob;
  row.value = value;
  row.variant = pr.name;
  row.error_name = "residual";
  row.error = FcError(pr.p, r);
  row.error_unit = "Siconos fc3d error";
  row.time_ms = Median(ms);
  row.time_what = "NSGS solve from zero forces, " + std::to_string(pr.p.contacts) + " contacts";
  row.detail = std::to_string(res.nsgs.iterations) + " sweeps" + (res.nsgs.converged ? "" : ", at the cap");
  emit(row);
  return res.nsgs.converged;
}

// ---- pinch-hold threshold (validation.cpp's three-finger pinch, friction ramped down) ----

struct PinchRamp {
  double mu_slip = NAN;  // mu / mu* at which the prism started to slip
  bool slipped = false;
  double step_ms = NAN;
  int unconverged = 0;
};

// The prism is squeezed with P by three driven fingertips, lifted, held at
// mu = mu_hi mu*, then mu falls linearly to mu_lo mu*. Slip: the prism's height
// relative to the fingertips falls faster than kSlipSpeed over 10 ms; the lag of
// that detection behind the threshold (a rigid prism's slip dynamics) is added
// back, so a perfect simulator would report mu* itself.
constexpr double kSlipSpeed = 1e-3;  // m/s
PinchRamp RunPinchRamp(const NsgsParams& solver, bool quick) {
  const double m = 0.1, P = 1.0, mu_star = m * kG / (3.0 * P);
  const double mu_hi = 1.05, mu_lo = 0.95;
  const double squeeze = quick ? 0.15 : 0.2, lift_time = 0.5, settle = 0.3;
  const double ramp = quick ? 0.5 : 2.0, lift = 0.03;
  auto w = std::make_unique<World>();
  w->params.dt = 1e-3;
  w->params.solver = solver;
  PinchRigSpec spec;
  spec.prism_mass = m;
  spec.squeeze_force = P;
  spec.prism_points = quick ? 4000 : 8000;
  spec.prism_control_points = quick ? 500 : 1000;
  const PinchRig rig = AddPinchRig(*w, spec);
  const int prism = rig.prism;
  const std::vector<int>& tips = rig.tips;
  const std::vector<Pose>& start = rig.tip_start;
  PinchRamp out;
  if (!rig.ok()) return out;
  w->Finalize();
  const double dt = w->params.dt;
  const double t_ramp = squeeze + lift_time + settle, t_end = t_ramp + ramp;
  const int window = static_cast<int>(std::lround(0.01 / dt));
  std::vector<double> rel;  // prism height relative to the fingertips, per step
  std::vector<double> ms;
  out.mu_slip = mu_lo;
  while (w->time < t_end - 0.5 * dt) {
    const double t = w->time + dt;
    const double f = t < t_ramp ? mu_hi : mu_hi + (mu_lo - mu_hi) * (t - t_ramp) / ramp;
    for (int k : tips) w->SetFriction(k, prism, f * mu_star);
    const double rise = lift * std::clamp((t - squeeze) / lift_time, 0.0, 1.0);
    for (size_t k = 0; k < tips.size(); ++k) {
      w->bodies[tips[k]].drive.target = start[k];
      w->bodies[tips[k]].drive.target.t.z() += rise;
    }
    w->Step();
    ms.push_back(1e3 * w->profile.total);
    out.unconverged += w->profile.converged ? 0 : 1;
    double tip_z = 0;
    for (int k : tips) tip_z += w->bodies[k].pose.t.z() / 3.0;
    rel.push_back(w->bodies[prism].pose.t.z() - tip_z);
    if (!std::isfinite(rel.back())) {
      out.slipped = true;
      out.mu_slip = f;
      break;
    }
    // fell during the lift (the fingertips' give under the load is a few mm at most): slipped at mu_hi
    if (std::abs(t - t_ramp) < 0.5 * dt && rel.back() < rel[static_cast<size_t>(squeeze / dt)] - 0.01) {
      out.slipped = true;
      out.mu_slip = mu_hi;
      break;
    }
    // watched through the ramp (the lift's transients have died out by then)
    if (t >= t_ramp && static_cast<int>(rel.size()) > window) {
      const double v = (rel.back() - rel[rel.size() - 1 - window]) / (window * dt);
      if (v < -kSlipSpeed) {
        out.slipped = true;
        // a rigid prism slips with a = g (1 - mu / mu*): at the ramp's rate k (mu* per s) it reaches
        // the speed v_s when mu is sqrt(2 k v_s / g) mu* below the threshold, which is added back
        out.mu_slip = f + std::sqrt(2.0 * (mu_hi - mu_lo) / ramp * kSlipSpeed / kG);
        break;
      }
    }
  }
  out.step_ms = Median(ms);
  return out;
}

void PinchRow(const NsgsParams& np, const char* knob, double value, bool quick, Emitter& emit) {
  const PinchRamp p = RunPinchRamp(np, quick);
  TradeoffRow r;
  r.knob = knob;
  r.value = value;
  r.variant = "pinch";
  r.error_name = "pinch_threshold";
  r.error = std::abs(p.mu_slip - 1.0);
  r.error_unit = "relative";
  r.time_ms = p.step_ms;
  r.time_what = "step, prism pinched by three fingertips";
  char d[200];
  if (p.slipped)
    std::snprintf(d, sizeof d, "slipped at mu = %.4f mu* (ramp 1.05 to 0.95); %d steps at the sweep cap", p.mu_slip,
                  p.unconverged);
  else
    std::snprintf(d, sizeof d, "still held at mu = 0.95 mu* (error at least 5%%); %d steps at the sweep cap",
                  p.unconverged);
  r.detail = d;
  emit(r);
}

void SweepSolver(const TradeoffOptions& opt, bool tolerance_knob, Emitter& emit) {
  const std::vector<NamedProblem> problems = SolverProblems(opt.quick);
  if (tolerance_knob) {
    const std::vector<double> tols =
        opt.quick ? std::vector<double>{1e-2, 1e-4, 1e-6} : std::vector<double>{1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8};
    for (const NamedProblem& pr : problems)
      for (double tol : tols) {
        NsgsParams np;
        np.tolerance = tol;
        np.max_iterations = 20000;
        if (!SolveRow(pr, np, "gs_tolerance", tol, opt.quick, emit)) break;  // stalled: tighter will not help
      }
    const std::vector<double> pinch_tols =
        opt.quick ? std::vector<double>{1e-8} : std::vector<double>{1e-2, 1e-3, 1e-4, 1e-6, 1e-9};
    for (double tol : opt.pinch ? pinch_tols : std::vector<double>{}) {
      NsgsParams np;
      np.tolerance = tol;
      np.max_iterations = 1000;
      PinchRow(np, "gs_tolerance", tol, opt.quick, emit);
    }
  } else {
    const std::vector<int> caps =
        opt.quick ? std::vector<int>{2, 10, 50} : std::vector<int>{1, 2, 5, 10, 20, 50, 100, 200, 500};
    for (const NamedProblem& pr : problems)
      for (int cap : caps) {
        NsgsParams np;
        np.tolerance = 0.0;  // the cap binds
        np.max_iterations = cap;
        SolveRow(pr, np, "gs_iterations", cap, opt.quick, emit);
      }
    const std::vector<int> pinch_caps = opt.quick ? std::vector<int>{1} : std::vector<int>{1, 3, 10, 30, 100};
    for (int cap : opt.pinch ? pinch_caps : std::vector<int>{}) {
      NsgsParams np;
      np.tolerance = 1e-12;
      np.max_iterations = cap;
      PinchRow(np, "gs_iterations", cap, opt.quick, emit);
    }
  }
}

// ---- time step: trajectory error against a small-dt reference ----

// A rigid box set flat on a plane tilted 25 degrees (mu 0.3), thrown across the
// slope and spinning about the plane's normal: friction curves its path downhill
// and stops the spin. Smooth (no impacts, no tumbling), so the difference to a
// small-dt run is the time discretisation's, not chaos. Positions every 10 ms.
std::vector<Vec3> BoxTrajectory(double dt, double duration, double* wall_ms_per_s) {
  auto w = std::make_unique<World>();
  w->params.dt = dt;
  w->params.default_friction = 0.3;
  w->params.solver.tolerance = 1e-8;
  w->params.solver.max_iterations = 500;
  const Pose plane = Pose::FromAxisAngle(Vec3::UnitY(), 25.0 * M_PI / 180.0);
  AddBody(*w, PlaneSpec("slope", plane));
  BodySpec b;
  b.name = "box";
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3(0.015, 0.01, 0.008);
  b.geometry.points = 3000;
  b.geometry.control_points = 400;
  b.mass = 0.05;
  // resting height: the lowest control point on the plane
  b.pose = Pose{plane.R, plane.Apply(Vec3(0, 0, 0.008))};
  b.velocity = plane.R * Vec3(0, 0.3, 0);
  const int box = AddBody(*w, b);
  std::vector<Vec3> out;
  if (box < 0) return out;
  w->Finalize();
  double lowest = 0;
  for (const Vec3& c : w->bodies[box].geometry.tree.control_points()) lowest = std::min(lowest, c.z());
  w->bodies[box].pose.t = plane.Apply(Vec3(0, 0, -lowest));
  w->bodies[box].pose_prev = w->bodies[box].pose;
  w->bodies[box].angular_velocity = plane.R * Vec3(0, 0, 4.0);
  const int per_sample = static_cast<int>(std::lround(0.01 / dt));
  const int samples = static_cast<int>(std::lround(duration / 0.01));
  const double t0 = Now();
  out.push_back(w->bodies[box].pose.t);
  for (int s = 0; s < samples; ++s) {
    for (int i = 0; i < per_sample; ++i) w->Step();
    out.push_back(w->bodies[box].pose.t);
  }
  *wall_ms_per_s = 1e3 * (Now() - t0) / duration;
  return out;
}

void SweepDt(const TradeoffOptions& opt, Emitter& emit) {
  const double duration = opt.quick ? 0.3 : 0.6;
  const std::vector<double> dts =
      opt.quick ? std::vector<double>{5e-3, 1e-3} : std::vector<double>{1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4};
  double ref_ms = 0;
  const std::vector<Vec3> ref = BoxTrajectory(1e-4, duration, &ref_ms);
  for (double dt : dts) {
    double ms = 0;
    const std::vector<Vec3> x = BoxTrajectory(dt, duration, &ms);
    double worst = NAN;
    if (x.size() == ref.size() && !ref.empty()) {
      worst = 0;
      for (size_t i = 0; i < x.size(); ++i) worst = std::max(worst, (x[i] - ref[i]).norm());
      if (!std::isfinite(worst)) worst = NAN;
    }
    TradeoffRow r;
    r.knob = "dt";
    r.value = dt;
    r.error_name = "trajectory";
    r.error = worst;
    r.error_unit = "m";
    r.time_ms = ms;
    r.time_what = "wall time per simulated second, box sliding and spinning down a slope";
    char d[160];
    std::snprintf(d, sizeof d, "largest distance from the dt = 1e-4 s run over %.1f s, sampled every 10 ms (reference: "
                  "%.0f ms per simulated s)", duration, ref_ms);
    r.detail = d;
    emit(r);
  }
}

std::string SeriesKey(const TradeoffRow& r) { return r.knob + (r.variant.empty() ? "" : "_" + r.variant) + "_" + r.error_name; }

std::string JsonEscape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    o += c;
  }
  return o;
}

std::string Num(double x) {
  if (!std::isfinite(x)) return "null";
  char b[40];
  std::snprintf(b, sizeof b, "%.6g", x);
  return b;
}

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string o = "\"";
  for (char c : s) o += c == '"' ? std::string("\"\"") : std::string(1, c);
  return o + "\"";
}

std::string NoGnuplot() { return std::string(plot::kGnuplotMissing) + ", so no PNG plots"; }

}  // namespace

std::vector<std::string> TradeoffKnobs() {
  return {"surface_points", "bandwidth", "control_points", "gs_tolerance", "gs_iterations", "dt"};
}

std::vector<TradeoffRow> RunTradeoff(const TradeoffOptions& opt, void (*progress)(const TradeoffRow&)) {
  std::vector<TradeoffRow> rows;
  Emitter emit{&rows, progress};
  auto want = [&](const char* k) { return opt.only.empty() || opt.only == k; };
  try {
    if (want("surface_points")) SweepSurfacePoints(opt, emit);
    if (want("bandwidth")) SweepBandwidth(opt, emit);
    if (want("control_points")) SweepControlPoints(opt, emit);
    if (want("gs_tolerance")) SweepSolver(opt, true, emit);
    if (want("gs_iterations")) SweepSolver(opt, false, emit);
    if (want("dt")) SweepDt(opt, emit);
  } catch (const Emitter::Stopped&) {
  }
  // series together, in the order they first appeared
  std::map<std::string, size_t> first;
  for (size_t i = 0; i < rows.size(); ++i) first.emplace(SeriesKey(rows[i]), i);
  std::stable_sort(rows.begin(), rows.end(), [&](const TradeoffRow& a, const TradeoffRow& b) {
    return first[SeriesKey(a)] < first[SeriesKey(b)];
  });
  MarkPareto(&rows);
  return rows;
}

void MarkPareto(std::vector<TradeoffRow>* rows) {
  std::vector<TradeoffRow>& v = *rows;
  for (size_t i = 0; i < v.size(); ++i) {
    v[i].pareto = std::isfinite(v[i].error) && std::isfinite(v[i].time_ms);
    if (!v[i].pareto) continue;
    for (size_t j = 0; j < v.size() && v[i].pareto; ++j) {
      if (j == i || SeriesKey(v[j]) != SeriesKey(v[i]) || !std::isfinite(v[j].error) || !std::isfinite(v[j].time_ms))
        continue;
      const bool no_worse = v[j].error <= v[i].error && v[j].time_ms <= v[i].time_ms;
      const bool better = v[j].error < v[i].error || v[j].time_ms < v[i].time_ms;
      if (no_worse && better) v[i].pareto = false;
    }
  }
}

std::string TradeoffJson(const TradeoffRow& r) {
  return "{\"knob\":\"" + r.knob + "\",\"value\":" + Num(r.value) + ",\"variant\":\"" + JsonEscape(r.variant) +
         "\",\"error_name\":\"" + r.error_name + "\",\"error\":" + Num(r.error) + ",\"error_unit\":\"" +
         JsonEscape(r.error_unit) + "\",\"time_ms\":" + Num(r.time_ms) + ",\"time_what\":\"" + JsonEscape(r.time_what) +
         "\",\"pareto\":" + (r.pareto ? "true" : "false") + ",\"detail\":\"" + JsonEscape(r.detail) + "\"}";
}

bool WriteTradeoffOutputs(const std::string& dir, const std::vector<TradeoffRow>& rows, std::vector<std::string>* pngs,
                          std::string* error) {
  ::mkdir(dir.c_str(), 0777);  // an existing directory is fine; a failure shows when the CSV is opened
  const std::string csv = dir + "/tradeoff.csv";
  FILE* f = std::fopen(csv.c_str(), "w");
  if (!f) {
    *error = "cannot write " + csv + " (is '" + dir + "' a writable directory?)";
    return false;
  }
  std::fprintf(f, "knob,value,variant,error_name,error,error_unit,time_ms,time_what,pareto,detail\n");
  for (const TradeoffRow& r : rows)
    std::fprintf(f, "%s,%s,%s,%s,%s,%s,%s,%s,%d,%s\n", r.knob.c_str(), Num(r.value).c_str(), CsvField(r.variant).c_str(),
                 r.error_name.c_str(), Num(r.error).c_str(), CsvField(r.error_unit).c_str(), Num(r.time_ms).c_str(),
                 CsvField(r.time_what).c_str(), r.pareto ? 1 : 0, CsvField(r.detail).c_str());
  if (std::fclose(f) != 0) {
    *error = "cannot write " + csv;
    return false;
  }
  if (!plot::GnuplotFound()) {
    *error = NoGnuplot() + ": wrote " + csv + " but no PNG plots";
    return false;
  }
  // one data file and one plot per series; rows sorted by error so that the front is a line
  std::map<std::string, std::vector<const TradeoffRow*>> series;
  for (const TradeoffRow& r : rows)
    if (std::isfinite(r.error) && std::isfinite(r.time_ms)) series[SeriesKey(r)].push_back(&r);
  const std::string script = dir + "/tradeoff.gp";
  FILE* gp = std::fopen(script.c_str(), "w");
  if (!gp) {
    *error = "cannot write " + script;
    return false;
  }
  std::fprintf(gp, "set terminal pngcairo size 900,650 noenhanced font ',11'\nset logscale xy\nset grid\n"
                   "set key top right\nset format x '%%.0e'\nset format y '%%g'\n");
  std::vector<std::string> written;
  std::string overview;  // every series in one figure, three panels a row
  for (auto& [key, v] : series) {
    std::sort(v.begin(), v.end(), [](const TradeoffRow* a, const TradeoffRow* b) { return a->error < b->error; });
    const std::string dat = dir + "/tradeoff_" + key + ".dat";
    FILE* d = std::fopen(dat.c_str(), "w");
    if (!d) {
      std::fclose(gp);
      *error = "cannot write " + dat;
      return false;
    }
    // log axes: an error of exactly 0 is drawn at 1e-16
    for (const TradeoffRow* r : v)
      std::fprintf(d, "%.9g %.9g %d %s\n", std::max(r->error, 1e-16), r->time_ms, r->pareto ? 1 : 0,
                   Num(r->value).c_str());
    std::fclose(d);
    const TradeoffRow& r0 = *v.front();
    const std::string png = dir + "/tradeoff_" + key + ".png";
    std::fprintf(gp,
                 "set output '%s'\nset title \"%s%s%s: time against %s error\"\n"
                 "set xlabel \"%s error (%s)\"\nset ylabel \"time (ms): %s\"\n"
                 "plot '%s' using 1:2 with points pt 7 ps 1.3 lc rgb '#7f7f7f' title 'settings', "
                 "'' using ($3==1?$1:1/0):2 with linespoints lw 2 pt 7 ps 1.6 lc rgb '#d62728' title 'Pareto front', "
                 "'' using 1:2:4 with labels offset 1.2,0.6 font ',9' notitle\n",
                 png.c_str(), r0.knob.c_str(), r0.variant.empty() ? "" : " / ", r0.variant.c_str(), r0.error_name.c_str(),
                 r0.error_name.c_str(), JsonEscape(r0.error_unit).c_str(), JsonEscape(r0.time_what).c_str(), dat.c_str());
    written.push_back(png);
    overview += "set title \"" + r0.knob + (r0.variant.empty() ? "" : " / " + r0.variant) + ": " + r0.error_name +
                "\"\nset xlabel \"" +
                r0.error_name + " (" + JsonEscape(r0.error_unit) + ")\"\nplot '" + dat +
                "' using 1:2 with points pt 7 lc rgb '#7f7f7f' notitle, '' using ($3==1?$1:1/0):2 with linespoints "
                "lw 2 pt 7 lc rgb '#d62728' notitle, '' using 1:2:4 with labels offset 1,0.5 font ',8' notitle\n";
  }
  if (!series.empty()) {
    const int rows_n = (static_cast<int>(series.size()) + 2) / 3;
    const std::string png = dir + "/tradeoff_overview.png";
    std::fprintf(gp,
                 "set terminal pngcairo size 1500,%d noenhanced font ',10'\nset output '%s'\n"
                 "set multiplot layout %d,3 title 'graspsim bench tradeoff: time (ms, y) against error (x); red: "
                 "Pareto front'\nset ylabel 'time (ms)'\n%sunset multiplot\n",
                 420 * rows_n, png.c_str(), rows_n, overview.c_str());
    written.push_back(png);
  }
  std::fclose(gp);
  if (!plot::RunGnuplot(script, error)) return false;
  if (pngs) *pngs = written;
  return true;
}

namespace {
bool g_json_progress = false;
void PrintProgress(const TradeoffRow& r) {
  if (g_json_progress) return;
  std::fprintf(stderr, "  measured %s = %g%s%s: %s %.3g %s, %.4g ms\n", r.knob.c_str(), r.value,
               r.variant.empty() ? "" : " on ", r.variant.c_str(), r.error_name.c_str(), r.error, r.error_unit.c_str(),
               r.time_ms);
}
}  // namespace

int RunBenchTradeoff(const BenchOptions& opt) {
  TradeoffOptions to;
  to.quick = opt.quick;
  to.only = opt.knob;
  g_json_progress = opt.json;
  // before a sweep of minutes: the output directory must be writable; without gnuplot, say so now
  // (the CSV is still written, and the run ends with status 4)
  if (!opt.plot_dir.empty()) {
    ::mkdir(opt.plot_dir.c_str(), 0777);
    const std::string probe = opt.plot_dir + "/tradeoff.csv";
    FILE* f = std::fopen(probe.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "graspsim bench tradeoff: cannot write %s (is '%s' a writable directory?)\n",
                   probe.c_str(), opt.plot_dir.c_str());
      return kExitMissingTool;
    }
    std::fclose(f);
    if (!plot::GnuplotFound())
      std::fprintf(stderr, "graspsim bench tradeoff: %s; only the CSV will be written\n", NoGnuplot().c_str());
  }
  const double t0 = Now();
  if (!opt.json)
    std::fprintf(stderr, "graspsim bench tradeoff: sweeping %s%s (one core)\n",
                 opt.quick ? "a shortened set of " : "", "surface points, bandwidth, control points, GS tolerance and "
                 "sweep cap, dt");
  std::vector<TradeoffRow> rows = RunTradeoff(to, PrintProgress);
  const double seconds = Now() - t0;
  int pareto = 0, unmeasured = 0;
  for (const TradeoffRow& r : rows) {
    pareto += r.pareto ? 1 : 0;
    unmeasured += std::isfinite(r.error) && std::isfinite(r.time_ms) ? 0 : 1;
  }
  std::vector<std::string> pngs;
  std::string error;
  bool plotted = true;
  if (!opt.plot_dir.empty()) plotted = WriteTradeoffOutputs(opt.plot_dir, rows, &pngs, &error);
  if (opt.json) {
    for (const TradeoffRow& r : rows) std::printf("%s\n", TradeoffJson(r).c_str());
    std::printf("{\"bench\":\"tradeoff\",\"rows\":%zu,\"pareto_rows\":%d,\"unmeasured\":%d,\"plots\":%zu,"
                "\"seconds\":%.1f,\"interrupted\":%s}\n",
                rows.size(), pareto, unmeasured, pngs.size(), seconds, StopRequested() ? "true" : "false");
  } else {
    std::printf("graspsim bench tradeoff: time (median) against the error each knob affects; * = on the Pareto front\n");
    std::string last;
    for (const TradeoffRow& r : rows) {
      const std::string key = r.knob + "|" + r.variant + "|" + r.error_name;
      if (key != last) {
        std::printf("\n  %s%s%s -> %s error (%s); time: %s\n", r.knob.c_str(), r.variant.empty() ? "" : " on ",
                    r.variant.c_str(), r.error_name.c_str(), r.error_unit.c_str(), r.time_what.c_str());
        std::printf("  %12s %12s %12s   %s\n", "value", "error", "time ms", "detail");
        last = key;
      }
      std::printf("  %12g %12.4g %12.4g %s %s\n", r.value, r.error, r.time_ms, r.pareto ? "*" : " ", r.detail.c_str());
    }
    std::printf("\n  %zu settings, %d on a Pareto front, %.1f s%s\n", rows.size(), pareto, seconds,
                StopRequested() ? " (interrupted: the sweep stopped there)" : "");
    if (!pngs.empty()) std::printf("  wrote %s/tradeoff.csv and %zu PNG plots\n", opt.plot_dir.c_str(), pngs.size());
  }
  if (!plotted) {
    std::fprintf(stderr, "graspsim bench tradeoff: %s\n", error.c_str());
    return kExitMissingTool;
  }
  return unmeasured == 0 ? 0 : 1;
}

}  // namespace gs::app
