// The stack and scale validations: a heavy box resting off-centre on a light
// box, on a table, with friction. Nothing may move: the stack must stand and
// neither box walk, at every mass ratio, at the default solver settings (the
// solver's stopping measure is scale-invariant, core/nsgs.h). And the same scene
// with every mass multiplied by k must follow the same trajectory with the same
// sweeps per step: scaling the masses scales every force by k and changes nothing
// else.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include "scene/code_scenes.h"
#include "validate/validation_util.h"
#include "core/world.h"
#include "session/console.h"

namespace gs::app {
namespace {

constexpr double kHalf = 0.02;      // both boxes: 4 cm cubes
constexpr double kLight = 0.1;      // kg, the bottom box
constexpr double kOffset = 0.005;   // m, the top box off the bottom box's centre
constexpr double kMu = 0.5;

struct StackRun {
  std::vector<Vec3> top, bottom;  // centres after each step
  std::vector<int> sweeps;        // Gauss-Seidel sweeps of each step
  double walk = 0.0;              // m/s: the faster box's horizontal speed over the run's second half
  double settled = 0.0;           // s: when the boxes last moved more than 10 nm horizontally in a step
  double sag = 0.0;               // m: how far the top box sank over the run
  double jump = 0.0;              // m: the most a box rose above where it ends
  int unconverged = 0;
  int max_sweeps = 0;
  int newton_steps = 0;  ///< steps that Newton continued after NSGS
  bool finite = true;
};

BodySpec StackBox(const char* name, double mass, const Vec3& at, uint64_t seed) {
  BodySpec b;
  b.name = name;
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3::Constant(kHalf);
  b.geometry.points = 1500;
  b.geometry.control_points = 200;
  b.geometry.seed = seed;
  b.mass = mass;
  b.pose = Pose::Translation(at);
  return b;
}

/// The top box weighs `ratio` times the bottom one; every mass times `scale`.
/// Default solver settings but the sweep cap. Settles for `settle` s, then runs
/// `seconds` s more. `apart`: how far above touching each box is set (m); `seed`:
/// both boxes' sampling seed.
StackRun RunStack(double ratio, double scale, double settle, double seconds, int max_sweeps, double apart = 3e-4,
                  uint64_t seed = 1) {
  World w;
  w.params.dt = 1e-3;
  w.params.solver.max_iterations = max_sweeps;
  w.params.default_friction = kMu;
  AddBody(w, PlaneSpec("table", Pose()));
  // a little apart by default (sharp edges' MLS surface bulges by a fraction of the spacing)
  const int bottom = AddBody(w, StackBox("bottom", kLight * scale, Vec3(0, 0, kHalf + apart), seed));
  const int top = AddBody(w, StackBox("top", ratio * kLight * scale, Vec3(kOffset, 0, 3 * kHalf + 2 * apart), seed));
  w.Finalize();
  StackRun r;
  const int settle_steps = static_cast<int>(std::lround(settle / w.params.dt));
  const int steps = settle_steps + static_cast<int>(std::lround(seconds / w.params.dt));
  Vec3 top0 = Vec3::Zero(), bottom0 = Vec3::Zero();
  for (int i = 0; i < steps; ++i) {
    if (i == settle_steps) {
      top0 = w.bodies[top].pose.t;
      bottom0 = w.bodies[bottom].pose.t;
    }
    w.Step();
    if (StopRequested()) break;  // Ctrl-C: the case ends here, reported as interrupted
    r.top.push_back(w.bodies[top].pose.t);
    r.bottom.push_back(w.bodies[bottom].pose.t);
    r.sweeps.push_back(w.profile.iterations);
    r.finite &= r.top.back().allFinite() && r.bottom.back().allFinite() && !w.profile.rejected;
    r.unconverged += w.profile.converged ? 0 : 1;
    r.max_sweeps = std::max(r.max_sweeps, w.profile.iterations);
    r.newton_steps += w.profile.newton_steps > 0 ? 1 : 0;
  }
  double top_high = -INFINITY, bottom_high = -INFINITY;
  for (const Vec3& p : r.top) top_high = std::max(top_high, p[2]);
  for (const Vec3& p : r.bottom) bottom_high = std::max(bottom_high, p[2]);
  r.jump = std::max(top_high - w.bodies[top].pose.t[2], bottom_high - w.bodies[bottom].pose.t[2]);
  const auto horizontal = [](const Vec3& d) { return std::hypot(d[0], d[1]); };
  // a walk is a steady drift; the landing's rocking on the MLS faces' bulges is not
  // (it decays within 0.5 s), so the walk is read over the second half of the run
  const size_t mid = settle_steps + (r.top.size() - settle_steps) / 2, last = r.top.size() - 1;
  if (r.top.size() > static_cast<size_t>(settle_steps) + 2)
    r.walk = std::max(horizontal(r.top[last] - r.top[mid]), horizontal(r.bottom[last] - r.bottom[mid])) /
             (static_cast<double>(last - mid) * w.params.dt);
  for (size_t i = 1; i < r.top.size(); ++i)
    if (std::max(horizontal(r.top[i] - r.top[i - 1]), horizontal(r.bottom[i] - r.bottom[i - 1])) > 1e-8)
      r.settled = static_cast<double>(i + 1) * w.params.dt;
  r.sag = top0[2] - w.bodies[top].pose.t[2];
  return r;
}

double SweepTotal(const StackRun& r) {
  double n = 0.0;
  for (const int s : r.sweeps) n += s;
  return n;
}

/// Largest distance between the two runs' box centres over all steps (m).
double TrajectoryGap(const StackRun& a, const StackRun& b) {
  if (a.top.size() != b.top.size()) return INFINITY;
  double gap = 0.0;
  for (size_t i = 0; i < a.top.size(); ++i)
    gap = std::max({gap, (a.top[i] - b.top[i]).norm(), (a.bottom[i] - b.bottom[i]).norm()});
  return gap;
}

/// Steps whose sweep counts differ between the runs.
int SweepMismatches(const StackRun& a, const StackRun& b) {
  if (a.sweeps.size() != b.sweeps.size()) return static_cast<int>(std::max(a.sweeps.size(), b.sweeps.size()));
  int n = 0;
  for (size_t i = 0; i < a.sweeps.size(); ++i) n += a.sweeps[i] != b.sweeps[i] ? 1 : 0;
  return n;
}

}  // namespace

// Every mass ratio at the default sweep cap (100). NSGS alone needs sweeps in
// proportion to the ratio (1,000 at ratio 10, 3,000 at 100, and more than 3,000
// at 1,000, walking ~1e-4 m/s there); a step it leaves unconverged continues with
// the Newton method (core/solver.cpp ContinueWithNewton), which these cases check.
struct StackCase {
  double ratio;
  int cap;
};
constexpr StackCase kStackCases[] = {{1.0, 100}, {10.0, 100}, {100.0, 100}, {1000.0, 100}};
// Both boxes' sampling seeds; a case is the worst over them. The MLS faces bulge
// where their sampling puts them, so where the stack rests and how long its landing
// rocks depend on the seed (0.05 to 0.46 s over these three); with seed 3 at ratio
// 1,000, a Newton run from the unconverged NSGS forces alone left the stack walking
// 1.3e-4 m/s (core/solver.cpp NewtonFromTwoStarts).
constexpr uint64_t kStackSeeds[] = {1, 3, 4};

std::vector<ValidationResult> ValidateStack(const ValidationOptions& opt) {
  const double settle = opt.quick ? 0.3 : 0.5;
  const double seconds = opt.quick ? 0.7 : 10.0;
  std::vector<ValidationResult> out;
  for (const StackCase& c : kStackCases) {
    if (StopRequested()) break;
    StackRun r;
    uint64_t worst_seed = kStackSeeds[0];
    for (const uint64_t seed : kStackSeeds) {
      if (StopRequested()) break;
      StackRun s = RunStack(c.ratio, 1.0, settle, seconds, c.cap, 3e-4, seed);
      if (seed == kStackSeeds[0] || !s.finite || (r.finite && s.walk > r.walk)) {
        r = std::move(s);
        worst_seed = seed;
      }
    }
    char name[64], d[400];
    std::snprintf(name, sizeof name, "stack_ratio_%g", c.ratio);
    std::snprintf(d, sizeof d,
                  "%g kg on %g kg, %g mm off-centre, mu %g, tolerance 1e-6, cap %d sweeps, worst of sampling seeds "
                  "1, 3, 4 (seed %llu): walk %.3g m/s over the last %g s (limit 1e-6), last moved over 10 nm in a step at %.3g s, sank %.3g m, "
                  "%d unconverged steps, sweeps max %d, %d steps continued by Newton",
                  c.ratio * kLight, kLight, 1e3 * kOffset, kMu, c.cap, static_cast<unsigned long long>(worst_seed),
                  r.walk, seconds / 2, r.settled, r.sag, r.unconverged, r.max_sweeps, r.newton_steps);
    out.push_back(Result(name, r.finite ? r.walk : NAN, 1e-6, "m/s", d));
  }
  // set on each other at their nominal heights, as a scene would write them: each box
  // starts inside the MLS surface under it (its edges' bulge, 0.15 mm at these points)
  // and is pushed out of it; it must settle there, not be thrown (with the push-out's
  // speed kept the boxes rose 2.0 mm). Nothing moves but the push: limit 20 um.
  if (!StopRequested()) {
    const StackRun r = RunStack(1.0, 1.0, settle, 0.2, 100, 0.0);
    char d[320];
    std::snprintf(d, sizeof d,
                  "two 4 cm boxes set touching on a table: rose at most %.3g m above where they settle (limit 2e-5), "
                  "walk %.3g m/s",
                  r.jump, r.walk);
    out.push_back(Result("stack_placed_touching", r.finite ? r.jump : NAN, 2e-5, "m", d));
  }
  return out;
}

// Powers of two scale every force exactly in floating point: bit-identical runs and
// sweeps (limit 0). Other factors round differently in the last bit: trajectories
// within 1e-8 m, total sweeps within 15%: last-bit differences move a step's stop
// by a sweep or two on these non-unique forces (measured 1-6%), while a measure that
// mixed units would stop a x1000 run far earlier (tests/core/scale_test.cpp).
std::vector<ValidationResult> ValidateScale(const ValidationOptions& opt) {
  const double settle = opt.quick ? 0.3 : 0.5;
  const double seconds = opt.quick ? 0.3 : 2.0;
  const double ratio = 1.0;
  const StackRun base = RunStack(ratio, 1.0, settle, seconds, 100);
  std::vector<ValidationResult> out;
  if (StopRequested()) return out;
  for (const double k : {8.0, 1024.0, 10.0, 1000.0}) {
    const StackRun s = RunStack(ratio, k, settle, seconds, 100);
    if (StopRequested()) break;  // a run cut short has fewer steps than the base to compare
    const double gap = TrajectoryGap(base, s);
    const int mismatches = SweepMismatches(base, s);
    const double limit = std::exp2(std::round(std::log2(k))) == k ? 0.0 : 1e-8;
    char name[64], d[320];
    std::snprintf(name, sizeof name, "scale_x%g", k);
    std::snprintf(d, sizeof d,
                  "box stack, every mass x%g: largest distance between the two trajectories %.3g m over %zu steps "
                  "(limit %g m); %d steps with other sweep counts (%d unconverged steps)",
                  k, gap, base.top.size(), limit, mismatches, base.unconverged);
    const bool ok = base.finite && s.finite;
    out.push_back(Result(name, ok ? gap : NAN, limit, "m", d));
    std::snprintf(name, sizeof name, "scale_x%g_sweeps", k);
    if (limit == 0.0) {
      std::snprintf(d, sizeof d, "every mass x%g: steps whose sweep count differs from the unscaled run's (of %zu)",
                    k, base.sweeps.size());
      out.push_back(Result(name, ok ? mismatches : NAN, 0, "steps", d));
      continue;
    }
    // last-bit differences move the forces along the solution set of these
    // statically indeterminate contacts, where a step may stop a sweep earlier or later
    const double total = SweepTotal(base), total_k = SweepTotal(s);
    std::snprintf(d, sizeof d, "every mass x%g: %g sweeps in all against %g unscaled (limit 15%%)", k, total_k, total);
    out.push_back(Result(name, ok ? std::abs(total_k - total) / total : NAN, 0.15, "relative", d));
  }
  return out;
}

}  // namespace gs::app
