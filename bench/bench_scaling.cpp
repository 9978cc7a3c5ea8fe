// `graspsim bench scaling [--json] [--quick]`: how the step's time grows.
//  1. Against the contact count: a deformable slab lying on a plane, its control
//     points (and so its contacts) from ~50 to ~2,000. Fitted: the log-log slope
//     of the median step time against contacts (1 = linear).
//  2. Against points per object at a fixed contact count: a box of 10,000 to
//     500,000 surface points (fixed 400 control points) on a plane with a ball
//     resting on it, so that the ball's control points are projected onto the
//     box's MLS surface. The kernel bandwidth follows the spacing, so a
//     projection sees as many points at any density; what grows is the depth of
//     the tree. Fitted: the slope of the median step time against ln(points)
//     (ms per factor e) and the log-log slope (0 = flat).
// Medians over the timed steps, one core.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "bench/bench.h"
#include "scene/code_scenes.h"
#include "core/world.h"
#include "session/console.h"

namespace gs::app {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// least-squares slope of y against x
double Slope(const std::vector<double>& x, const std::vector<double>& y) {
  const int n = static_cast<int>(x.size());
  double mx = 0, my = 0;
  for (int i = 0; i < n; ++i) {
    mx += x[i] / n;
    my += y[i] / n;
  }
  double sxy = 0, sxx = 0;
  for (int i = 0; i < n; ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
  }
  return sxx > 0 ? sxy / sxx : NAN;
}

struct Timed {
  double step_ms = 0, collision_ms = 0, solve_ms = 0, space_ms = 0, motion_ms = 0;
  int contacts = 0, iterations = 0;
};

Timed TimeSteps(World& w, int settle, int steps) {
  for (int i = 0; i < settle; ++i) w.Step();
  std::vector<double> total, coll, solve, contacts, iters, space, motion;
  for (int i = 0; i < steps; ++i) {
    w.Step();
    const StepProfile& p = w.profile;
    total.push_back(1e3 * p.total);
    coll.push_back(1e3 * p.detect);
    solve.push_back(1e3 * p.solve);
    space.push_back(1e3 * (p.fill_w_rigid + p.fill_w_deform));
    motion.push_back(1e3 * (p.free_motion + p.constrained_motion));
    contacts.push_back(p.contacts);
    iters.push_back(p.iterations);
  }
  Timed t;
  t.step_ms = Median(total);
  t.collision_ms = Median(coll);
  t.solve_ms = Median(solve);
  t.space_ms = Median(space);
  t.motion_ms = Median(motion);
  t.contacts = static_cast<int>(Median(contacts));
  t.iterations = static_cast<int>(Median(iters));
  return t;
}

// a slab whose size gives about `contacts` contacts at a fixed control-point density
// (4,800 control points on a 12 x 12 x 0.8 cm slab give ~2,100 contacts)
Timed SlabRun(int contacts, int steps, int* cps_out) {
  const double area_ref = 2 * 0.12 * 0.12 + 4 * 0.12 * 0.008;
  const double side = 0.12 * std::sqrt(contacts / 2100.0);
  const double area = 2 * side * side + 4 * side * 0.008;
  const int cps = std::max(8, static_cast<int>(std::lround(4800 * area / area_ref)));
  *cps_out = cps;
  auto w = std::make_unique<World>();
  w->params.solver.max_iterations = 100;
  AddBody(*w, PlaneSpec("plane", Pose{}));
  BodySpec s;
  s.name = "slab";
  s.shape.type = EShape::Box;
  s.shape.half_extents = Vec3(0.5 * side, 0.5 * side, 0.004);
  s.geometry.points = 3 * cps;
  s.geometry.control_points = cps;
  s.mass = 0.3;
  s.pose = Pose::Translation(Vec3(0, 0, 0.0041));
  s.deformation.model = EDeformation::Gaussian;
  s.deformation.stiffness = 2000;
  s.deformation.damping = 0.5;
  s.deformation.influence_radius = 0.003;
  AddBody(*w, s);
  w->Finalize();
  return TimeSteps(*w, 30, steps);
}

Timed PointsRun(int points, int steps) {
  auto w = std::make_unique<World>();
  w->params.solver.max_iterations = 100;
  AddBody(*w, PlaneSpec("plane", Pose{}));
  BodySpec b;
  b.name = "box";
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3::Constant(0.03);
  b.geometry.points = points;
  b.geometry.control_points = 400;
  b.mass = 0.2;
  b.pose = Pose::Translation(Vec3(0, 0, 0.0301));
  AddBody(*w, b);
  BodySpec s;
  s.name = "ball";
  s.shape.type = EShape::Sphere;
  s.shape.radius = 0.01;
  s.geometry.points = 2000;
  s.geometry.control_points = 300;
  s.mass = 0.05;
  s.pose = Pose::Translation(Vec3(0.002, 0.001, 0.0702));
  AddBody(*w, s);
  w->Finalize();
  return TimeSteps(*w, 100, steps);
}

}  // namespace

int RunBenchScaling(const BenchOptions& opt) {
  const std::vector<int> targets =
      opt.quick ? std::vector<int>{50, 200, 500} : std::vector<int>{50, 100, 200, 500, 1000, 2000};
  const std::vector<int> points =
      opt.quick ? std::vector<int>{10000, 30000} : std::vector<int>{10000, 30000, 100000, 300000, 500000};
  const int steps = opt.quick ? 20 : 100;
  std::vector<double> lc, lt_c, lp, t_p, lt_p;
  if (!opt.json) std::printf("graspsim bench scaling: median step time (ms), %d timed steps each\n", steps);
  if (!opt.json) std::printf("  against contacts (deformable slabs on a plane, same density, growing size)\n"
                             "  %8s %8s %10s %10s %10s %10s %10s %6s\n",
                             "cps", "contacts", "step", "collision", "space", "solve", "motion", "sweeps");
  for (int target : targets) {
    if (StopRequested()) break;  // Ctrl-C: the rows measured so far are printed and fitted
    int c = 0;
    const Timed t = SlabRun(target, steps, &c);
    lc.push_back(std::log(std::max(1, t.contacts)));
    lt_c.push_back(std::log(t.step_ms));
    if (opt.json)
      std::printf("{\"series\":\"contacts\",\"control_points\":%d,\"contacts\":%d,\"step_ms\":%.4f,\"collision_ms\":%.4f,"
                  "\"contact_space_ms\":%.4f,\"solve_ms\":%.4f,\"motion_ms\":%.4f,\"sweeps\":%d}\n",
                  c, t.contacts, t.step_ms, t.collision_ms, t.space_ms, t.solve_ms, t.motion_ms, t.iterations);
    else
      std::printf("  %8d %8d %10.4f %10.4f %10.4f %10.4f %10.4f %6d\n", c, t.contacts, t.step_ms, t.collision_ms,
                  t.space_ms, t.solve_ms, t.motion_ms, t.iterations);
    std::fflush(stdout);
  }
  if (!opt.json) std::printf("  against points per object (box of N points, ball on it, fixed control points)\n"
                             "  %8s %8s %10s %10s %10s\n", "points", "contacts", "step", "collision", "solve");
  for (int n : points) {
    if (StopRequested()) break;
    const Timed t = PointsRun(n, steps);
    lp.push_back(std::log(n));
    t_p.push_back(t.step_ms);
    lt_p.push_back(std::log(t.step_ms));
    if (opt.json)
      std::printf("{\"series\":\"points\",\"points\":%d,\"contacts\":%d,\"step_ms\":%.4f,\"collision_ms\":%.4f,"
                  "\"solve_ms\":%.4f}\n",
                  n, t.contacts, t.step_ms, t.collision_ms, t.solve_ms);
    else
      std::printf("  %8d %8d %10.4f %10.4f %10.4f\n", n, t.contacts, t.step_ms, t.collision_ms, t.solve_ms);
    std::fflush(stdout);
  }
  const double slope_contacts = Slope(lc, lt_c);
  const double ms_per_ln_points = Slope(lp, t_p);
  const double loglog_points = Slope(lp, lt_p);
  const bool ok = slope_contacts <= 1.15;
  if (opt.json) {
    std::printf("{\"bench\":\"scaling\",\"loglog_slope_vs_contacts\":%.3f,\"step_ms_per_ln_points\":%.4f,"
                "\"loglog_slope_vs_points\":%.3f,\"contacts_at_most_linear\":%s}\n",
                slope_contacts, ms_per_ln_points, loglog_points, ok ? "true" : "false");
  } else {
    std::printf("  log-log slope of step time against contacts: %.3f (1 = linear)\n", slope_contacts);
    std::printf("  step time against ln(points): %.4f ms per factor e; log-log slope %.3f (0 = flat)\n",
                ms_per_ln_points, loglog_points);
  }
  return 0;
}

}  // namespace gs::app
