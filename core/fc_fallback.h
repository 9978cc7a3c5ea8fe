// Solver choice for explicit frictional contact problems (FcProblem): NSGS
// alone, the proximal semi-smooth Newton method alone (fc_newton.h), or auto:
// NSGS until its stagnation rule fires (NsgsParams::stagnation_window), then
// Newton from the NSGS forces, raced against the pace NSGS had: a Newton whose
// error falls more slowly per second stops (Outpaced) and NSGS goes on from the
// better forces under the rule again; stalled again, Newton races its new pace
// (up to 3 races, then NSGS without the rule to its cap). Every stage has its cap, and the result says
// which one ended the solve (EFcStop). A result that meets the tolerance only
// because the forces are huge (|r| mean(diag W) > 1e4 |q| while the error
// relative to |q| alone exceeds it) is reported as Diverged, not converged:
// Siconos' relative error falls as 1/|r| on an infeasible problem.
#pragma once

#include <Eigen/Core>
#include <string>

#include "core/fc_newton.h"
#include "core/fc_problem.h"

namespace gs {

enum class EFcMethod { Nsgs, Newton, Auto };

/// "nsgs", "newton", "auto".
const char* FcMethodName(EFcMethod m);

struct FcMethodParams {
  double tolerance = 1e-6;        ///< Siconos error
  int max_sweeps = 100000;        ///< NSGS sweep cap (auto: of its NSGS stage)
  int max_newton = 200;           ///< Newton step cap (factorisations)
  double time_budget_s = 0.0;     ///< whole solve (0: none)
  int stagnation_window = 200;    ///< auto: NSGS sweeps per progress check
  double stagnation_ratio = 0.5;  ///< auto: the best estimate must fall by this factor per window
  double over_relaxation = 1.0;
  ESweepOrder order = ESweepOrder::Forward;
  int extrapolate_every = 50;
};

struct FcMethodResult {
  EFcMethod method = EFcMethod::Auto;  ///< as asked
  NsgsResult nsgs;                     ///< NSGS stage (sweeps 0 when it did not run)
  FcNewtonResult newton;               ///< Newton stage (iterations 0 when it did not run)
  bool newton_ran = false;
  /// auto: Newton was outpaced by NSGS's pace before the stagnation, and NSGS went on
  /// from the better forces (its sweeps and time are added to `nsgs`, `nsgs_seconds`)
  bool nsgs_resumed = false;
  /// auto: a resumed NSGS stagnated again and Newton raced it again from its forces
  /// (`newton` then counts every Newton run)
  bool newton_rerun = false;
  double error = 0.0;                  ///< Siconos error of the returned forces
  bool converged = false;
  EFcStop stop = EFcStop::IterationCap;  ///< what ended the solve
  double nsgs_seconds = 0.0, newton_seconds = 0.0, seconds = 0.0;
  /// One line: the method, each stage's iterations and the stop reason.
  std::string Summary() const;
};

/// Solves from the forces in *r (zeroed when its size is not 3n).
FcMethodResult SolveFcMethod(const FcProblem& p, EFcMethod method, const FcMethodParams& params,
                             Eigen::VectorXd* r);

}  // namespace gs
