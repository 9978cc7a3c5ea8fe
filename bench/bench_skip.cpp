// `graspsim bench skip [--json] [--quick]`: what a scene pays for each feature.
// Per feature, two worlds that differ only in that feature are stepped in
// turns (one step of each, so that the machine's load falls on both alike) and
// the median step times are compared: the ratio without/with is what is left
// of the cost once the feature is gone (1 would mean nothing is skipped). The
// work counters of StepProfile::work show what each skipped (docs/skip.md).
#include <algorithm>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "bench/bench.h"
#include "core/world.h"
#include "session/console.h"

namespace gs::app {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

int AddPlane(World& w) {
  BodySpec plane;
  plane.name = "table";
  plane.is_plane = true;
  return AddBody(w, plane);
}

DeformationParams Soft() {
  DeformationParams d;
  d.model = EDeformation::Gaussian;
  d.stiffness = 2000;
  d.damping = 2;
  d.influence_radius = 0.004;
  return d;
}

// a free rigid cube named "box" of half side `half` centred at `at`
BodySpec Cube(const Vec3& at, double half, int points, int control_points, double mass) {
  BodySpec b;
  b.name = "box";
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3::Constant(half);
  b.geometry.points = points;
  b.geometry.control_points = control_points;
  b.mass = mass;
  b.pose = Pose::Translation(at);
  return b;
}

// nine 3 cm boxes resting on a table in a 3x3 grid (about 40 contacts each)
// (asleep after 0.1 s at rest unless `sleep`: the other features are measured awake)
void Boxes(World& w, double mu, bool deformable) {
  w.params.dt = 1e-3;
  w.params.sleep.enabled = false;
  w.params.default_friction = mu;
  w.params.solver.tolerance = 1e-6;
  w.params.solver.max_iterations = 100;
  AddPlane(w);
  for (int i = 0; i < 9; ++i) {
    BodySpec b = Cube(Vec3(0.05 * (i % 3), 0.05 * (i / 3), 0.0151), 0.015, 3000, 300, 0.1);
    if (deformable) b.deformation = Soft();
    AddBody(w, b);
  }
  w.Finalize();
}

// a stack of three deformable 2 cm boxes on a table, resting (sleep on or off);
// it settles in about 0.2 s and, with sleep, is asleep by 0.3 s
void Stack(World& w, bool sleep) {
  w.params.dt = 1e-3;
  w.params.default_friction = 0.8;
  w.params.solver.tolerance = 1e-6;
  w.params.solver.max_iterations = 100;
  w.params.sleep.enabled = sleep;
  AddPlane(w);
  for (int i = 0; i < 3; ++i) {
    BodySpec b = Cube(Vec3(0, 0, 0.0101 + i * 0.0202), 0.01, 1500, 200, 0.05);
    b.deformation.model = EDeformation::Gaussian;
    b.deformation.stiffness = 2000;
    b.deformation.damping = 5;
    b.deformation.influence_radius = 0.003;
    AddBody(w, b);
  }
  w.Finalize();
}

// sixteen deformable balls falling together in a 4x4 grid, `spacing` apart
// (bounding spheres overlap below ~2.1 cm); they never touch
void FallingBalls(World& w, double spacing) {
  w.params.dt = 1e-3;
  AddPlane(w);
  for (int i = 0; i < 16; ++i) {
    BodySpec s;
    s.name = "ball";
    s.shape.type = EShape::Sphere;
    s.shape.radius = 0.01;
    s.geometry.points = 2000;
    s.geometry.control_points = 250;
    s.mass = 0.05;
    s.pose = Pose::Translation(Vec3(spacing * (i % 4), spacing * (i / 4), 0.6));
    s.deformation = Soft();
    AddBody(w, s);
  }
  w.Finalize();
}

struct Side {
  double step_ms = 0, collision_ms = 0, space_ms = 0, solve_ms = 0, motion_ms = 0;
  int contacts = 0;
  StepWork work;  ///< of the last timed step
};

struct Case {
  const char* feature;
  const char* with_label;
  const char* without_label;
  std::function<void(World&)> build_with, build_without;
  int settle;
  // the counters that tell what the feature costs, printed for both sides
  std::vector<std::pair<const char*, int StepWork::*>> counters;
  bool settle_in_quick = false;  ///< --quick keeps the whole settling (the feature needs it)
};

struct Result {
  Side with, without;
  double ratio = 0.0;  ///< without / with, step medians
};

Result Measure(const Case& c, int settle, int steps) {
  World a, b;
  c.build_with(a);
  c.build_without(b);
  for (int i = 0; i < settle; ++i) {
    a.Step();
    b.Step();
  }
  std::vector<double> t[2], coll[2], space[2], solve[2], motion[2], contacts[2];
  World* worlds[2] = {&a, &b};
  for (int i = 0; i < steps; ++i) {
    for (int k = 0; k < 2; ++k) {
      // alternate which goes first so that neither always follows the other's cache traffic
      World& w = *worlds[(i + k) & 1];
      const int s = (i + k) & 1;
      w.Step();
      const StepProfile& p = w.profile;
      t[s].push_back(1e3 * p.total);
      coll[s].push_back(1e3 * p.detect);
      space[s].push_back(1e3 * (p.fill_w_rigid + p.fill_w_deform));
      solve[s].push_back(1e3 * p.solve);
      motion[s].push_back(1e3 * (p.free_motion + p.constrained_motion));
      contacts[s].push_back(p.contacts);
    }
  }
  Result r;
  Side* sides[2] = {&r.with, &r.without};
  for (int s = 0; s < 2; ++s) {
    Side& d = *sides[s];
    d.step_ms = Median(t[s]);
    d.collision_ms = Median(coll[s]);
    d.space_ms = Median(space[s]);
    d.solve_ms = Median(solve[s]);
    d.motion_ms = Median(motion[s]);
    d.contacts = static_cast<int>(Median(contacts[s]));
    d.work = worlds[s]->profile.work;
  }
  r.ratio = r.with.step_ms > 0 ? r.without.step_ms / r.with.step_ms : 0.0;
  return r;
}

std::vector<Case> Cases() {
  std::vector<Case> cases;
  cases.push_back({"friction", "mu 0.8", "mu 0",
                   [](World& w) { Boxes(w, 0.8, false); },
                   [](World& w) { Boxes(w, 0.0, false); },
                   200,
                   {{"local_solves_3d", &StepWork::local_solves_3d},
                    {"local_solves_normal", &StepWork::local_solves_normal}}});
  cases.push_back({"deformation", "gaussian", "rigid",
                   [](World& w) { Boxes(w, 0.8, true); },
                   [](World& w) { Boxes(w, 0.8, false); },
                   200,
                   {{"w_deform_sides", &StepWork::w_deform_sides},
                    {"propagations", &StepWork::propagations},
                    {"deformed_points", &StepWork::deformed_points},
                    {"refit_nodes", &StepWork::refit_nodes}}});
  // box on box: the side on the lower box's surface is interpolated over several of
  // its control points (a side on one control point merges nothing either way)
  cases.push_back({"changed contacts", "recomputed", "reused",
                   [](World& w) {
                     Stack(w, false);
                     w.params.reuse_contact_space = false;
                   },
                   [](World& w) { Stack(w, false); },
                   400,
                   {{"w_deform_sides", &StepWork::w_deform_sides},
                    {"w_deform_reused", &StepWork::w_deform_reused},
                    {"w_deform_direct", &StepWork::w_deform_direct}}});
  // the resting stack's box/box pairs: traversed every step (as pairs that moved
  // beyond the margin would be) against served from their leaf-pair caches
  cases.push_back({"pair motion", "traversed", "cached",
                   [](World& w) {
                     Stack(w, false);
                     w.params.collision.pair_cache_margin = 0.0;
                   },
                   [](World& w) { Stack(w, false); },
                   400,
                   {{"pairs_traversed", &StepWork::pairs_traversed},
                    {"pairs_from_cache", &StepWork::pairs_from_cache},
                    {"node_tests", &StepWork::node_tests}}});
  cases.push_back({"proximity", "2.05 cm apart", "10 cm apart",
                   [](World& w) { FallingBalls(w, 0.0205); },
                   [](World& w) { FallingBalls(w, 0.10); },
                   20,
                   {{"pair_tests", &StepWork::pair_tests},
                    {"pairs_traversed", &StepWork::pairs_traversed},
                    {"pairs_clear", &StepWork::pairs_clear}}});
  cases.push_back({"rest", "awake", "asleep",
                   [](World& w) { Stack(w, false); },
                   [](World& w) { Stack(w, true); },
                   400,
                   {{"bodies_asleep", &StepWork::bodies_asleep},
                    {"pair_tests", &StepWork::pair_tests},
                    {"pairs_traversed", &StepWork::pairs_traversed},
                    {"pairs_asleep", &StepWork::pairs_asleep},
                    {"contacts_reused", &StepWork::contacts_reused}},
                   true});
  return cases;
}

}  // namespace

int RunBenchSkip(const BenchOptions& opt) {
  const int steps = opt.quick ? 40 : 400;
  const std::vector<Case> cases = Cases();
  if (!opt.json) {
    std::printf("graspsim bench skip: each feature against the same scene without it, stepped in turns, %d steps\n",
                steps);
    std::printf("  %-12s %-14s %-14s %10s %10s %9s  %s\n", "feature", "with", "without", "with ms", "without ms",
                "without/with", "work (with -> without)");
  }
  double worst = 0.0;
  std::string worst_feature;
  for (const Case& c : cases) {
    if (StopRequested()) break;  // Ctrl-C: the features measured so far are printed
    const Result r = Measure(c, opt.quick && !c.settle_in_quick ? std::min(c.settle, 40) : c.settle, steps);
    if (r.ratio > worst) {
      worst = r.ratio;
      worst_feature = c.feature;
    }
    if (opt.json) {
      std::printf("{\"bench\":\"skip\",\"feature\":\"%s\",\"with\":\"%s\",\"without\":\"%s\",\"steps\":%d,", c.feature,
                  c.with_label, c.without_label, steps);
      const Side* sides[2] = {&r.with, &r.without};
      const char* tags[2] = {"with", "without"};
      for (int s = 0; s < 2; ++s) {
        const Side& d = *sides[s];
        std::printf("\"%s_step_ms_median\":%.4f,\"%s_collision_ms\":%.4f,\"%s_contact_space_ms\":%.4f,"
                    "\"%s_solve_ms\":%.4f,\"%s_motion_ms\":%.4f,\"%s_contacts\":%d,",
                    tags[s], d.step_ms, tags[s], d.collision_ms, tags[s], d.space_ms, tags[s], d.solve_ms, tags[s],
                    d.motion_ms, tags[s], d.contacts);
        for (const auto& [name, field] : c.counters) std::printf("\"%s_%s\":%d,", tags[s], name, d.work.*field);
      }
      std::printf("\"ratio_without_to_with\":%.3f}\n", r.ratio);
    } else {
      std::printf("  %-12s %-14s %-14s %10.4f %10.4f %9.2f   ", c.feature, c.with_label, c.without_label,
                  r.with.step_ms, r.without.step_ms, r.ratio);
      for (const auto& [name, field] : c.counters)
        std::printf(" %s %d -> %d;", name, r.with.work.*field, r.without.work.*field);
      std::printf("\n");
      std::printf("  %-12s   stages (ms) with:    collision %.4f, contact space %.4f, solve %.4f, motion %.4f; %d contacts\n",
                  "", r.with.collision_ms, r.with.space_ms, r.with.solve_ms, r.with.motion_ms, r.with.contacts);
      std::printf("  %-12s   stages (ms) without: collision %.4f, contact space %.4f, solve %.4f, motion %.4f; %d contacts\n",
                  "", r.without.collision_ms, r.without.space_ms, r.without.solve_ms, r.without.motion_ms,
                  r.without.contacts);
    }
  }
  if (opt.json) {
    std::printf("{\"bench\":\"skip\",\"features\":%d,\"steps\":%d,\"worst_feature\":\"%s\","
                "\"worst_ratio_without_to_with\":%.3f}\n",
                static_cast<int>(cases.size()), steps, worst_feature.c_str(), worst);
  } else {
    std::printf("  worst without/with: %.2f (%s); below 1 means the scene without the feature pays less\n", worst,
                worst_feature.c_str());
  }
  return 0;
}

}  // namespace gs::app
