// `graspsim stress`: the numerical stress matrix of DESIGN.md ("What fast and
// accurate means here"). Each case builds a small world that pushes one knob to
// an extreme (stiffness, time step, mass ratio, contact count, initial
// penetration, tracker teleports and NaNs, degenerate point clouds, friction,
// very long runs), steps it, and watches every step:
//   - NaN/Inf: any pose, velocity, joint, displacement, force or residual that
//     is not finite after a step (a step the World rejected is counted apart:
//     it kept its previous state, so nothing non-finite left it);
//   - penetration: the largest normal overlap of the deformed surfaces after
//     the solve (the contact space's gap W r + q, and, against planes, the
//     deformed control points below the plane), in metres;
//   - energy growth: max over time of E(t) - E(0), E = kinetic + gravitational
//     potential of the free bodies, in joules; plus the largest speed reached;
//   - solver: steps at the sweep cap (reported non-convergence), the largest
//     residual, and a spot check that the reported residual is the Siconos
//     error recomputed from an explicitly assembled W;
//   - pass: no non-finite value, penetration and energy growth within the
//     case's stated bounds, every residual within tolerance or reported as
//     non-converged, and the case's own physical expectation (a sliding block
//     slides, a held one holds). A case may instead be refused up front
//     (an ill-posed scene), and then passes when it is refused with its message.
#pragma once

#include <string>
#include <vector>

namespace gs::app {

struct StressOptions {
  bool quick = false;  ///< shortened runs (the million steps become 100,000): graspsim stress --quick
  bool tiny = false;   ///< shorter still and coarser (the test suite under sanitizers)
};

struct StressResult {
  std::string name;
  std::string what;               ///< the scene in words
  bool pass = false;
  bool refused = false;           ///< refused up front as ill-posed; `refusal` says why
  std::string refusal;
  int64_t steps = 0;
  int contacts_max = 0;
  int64_t nonfinite_steps = 0;    ///< steps after which some state value was NaN or Inf
  int64_t rejected_steps = 0;     ///< steps the World undid because they produced a non-finite value
  int64_t unconverged_steps = 0;  ///< steps whose solve stopped at the sweep cap (reported)
  int64_t misreported_steps = 0;  ///< residual above tolerance yet reported converged
  double residual_max = 0.0;
  double residual_check = 0.0;    ///< largest |reported - recomputed| / max(recomputed, tol) of the spot checks
  double penetration_max = 0.0;   ///< m
  double penetration_limit = 0.0; ///< m
  double energy_growth = 0.0;     ///< J, max_t E(t) - E(0)
  double energy_limit = 0.0;      ///< J
  double speed_max = 0.0;         ///< m/s, fastest free body
  bool expectation_ok = true;     ///< the case's own physical check
  std::string detail;             ///< what the case's own check measured, or why it failed
  double seconds = 0.0;           ///< wall time of the case
  bool interrupted = false;       ///< cut short by Ctrl-C or SIGTERM: no verdict (pass is false)
};

/// Case names, in the order they run.
std::vector<std::string> StressCaseNames();
/// Runs the cases whose names contain `filter` (all when empty).
std::vector<StressResult> RunStress(const StressOptions& opt, const std::string& filter = "");

/// One result as a JSON object (one line, no newline).
std::string StressJson(const StressResult& r);

}  // namespace gs::app
