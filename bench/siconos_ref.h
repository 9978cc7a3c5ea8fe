// Siconos Numerics (Debian libsiconos-numerics-dev) as the reference solver of
// `graspsim bench solver`: the same FcProblem handed to Siconos' NSGS, NSN-AC
// (semi-smooth Newton on Alart-Curnier) and PROX, timed, and the forces' error
// measured with Siconos' own fc3d_compute_error.
// Built only when the library is found (GRASPSIM_HAVE_SICONOS).
#pragma once

#include <Eigen/Core>
#include <string>

#include "core/fc_problem.h"

namespace gs::app {

enum class ESiconosSolver { Nsgs, NsnAc, Prox };

/// The solver's Siconos name (SICONOS_FRICTION_3D_...): "NSGS", "NSN_AC", "PROX".
const char* SiconosSolverName(ESiconosSolver solver);

struct SiconosRun {
  bool available = false;   ///< false when built without Siconos
  int info = -1;            ///< the driver's return code (0: its own test passed)
  int iterations = 0;
  double seconds = 0.0;     ///< the driver call alone (problem built beforehand)
  double error = NAN;       ///< fc3d_compute_error of the returned forces, normalised as SOLVER-REFERENCE says
  double tolerance = 0.0;   ///< the tolerance handed to Siconos
  int signal = 0;           ///< SolveWithSiconosIsolated: the signal that ended the solve (0: none)
};

/// True when Siconos is compiled in.
bool SiconosAvailable();

/// Solves p from zero forces with Siconos; Siconos' diagnostics (it prints on
/// stdout) are silenced. *r receives the forces when given.
SiconosRun SolveWithSiconos(const FcProblem& p, ESiconosSolver solver, double tolerance, int max_iterations,
                            Eigen::VectorXd* r = nullptr);

/// The same solve in a child process: Debian's Siconos keeps its asserts, and a
/// solver that aborts (or crashes) on a hard problem ends the child, not the caller.
/// Such a run comes back with `signal` set and no forces; otherwise as SolveWithSiconos.
SiconosRun SolveWithSiconosIsolated(const FcProblem& p, ESiconosSolver solver, double tolerance, int max_iterations,
                                    Eigen::VectorXd* r = nullptr);

}  // namespace gs::app
