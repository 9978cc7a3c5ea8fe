// A second solver for explicit frictional contact problems (FcProblem), for
// what Gauss-Seidel cannot finish: a semi-smooth Newton method on the
// Alart-Curnier function of the exact Coulomb law, regularised by a proximal
// term, with a backtracking line search.
//
// Alart-Curnier, per contact, with rho_c = 1 / max diag(W_cc):
//   phi_N = r_N - max(0, r_N - rho u_N)
//   phi_T = r_T - P_{disc of radius mu max(0, r_N - rho u_N)}(r_T - rho u_T)
// phi(r) = 0 exactly when r solves the Coulomb problem (u = W r + q), the same
// solutions as Siconos' error measure (local_solver.h) recognises.
//
// Proximal Newton: each step solves J_sigma d = -phi(r), with J_sigma the
// generalised Jacobian of phi for W + sigma I (the problem whose proximal centre
// is the current r), so the system stays non-singular when W is rank-deficient
// (statically indeterminate contacts) and the step is damped along W's null
// space. The step length halves until |phi_sigma(r + t d)| <= (1 - 1e-4 t)|phi(r)|.
// sigma starts at sigma0 mean(diag W), shrinks (x 1/4) after a full step, doubles
// after a shortened one and grows (x 10) after a failed search,
// so the method becomes plain semi-smooth Newton near a solution and a proximal
// point iteration far from it. The linear system is factorised by Eigen's sparse
// LU (its pattern analysed once). The convergence test is Siconos' error of the
// original problem (sigma = 0), and the forces returned are the best seen.
//
// The line search is non-monotone (Grippo, Lampariello and Lucidi 1986): a step
// is measured against the largest merit of the last kNonmonotone steps, not the
// current one, with a watchdog: kWatchdog steps without a new lowest error send
// the run back to its best forces, monotone for kNonmonotone steps. On stacks of
// boxes (four corner contacts per face, W rank-deficient, degenerate contacts with
// r_N = u_N = 0) the monotone rule cut nearly every step short and crawled: a
// 10-box stack at mass ratio 100 took 157 steps from zero, 24 with this rule.
#pragma once

#include <Eigen/Core>
#include <memory>

#include "core/fc_problem.h"

namespace gs {

/// Why a solve ended.
enum class EFcStop {
  Converged,         ///< Siconos error <= tolerance
  IterationCap,      ///< the cap on iterations (sweeps or Newton steps) was reached
  TimeCap,           ///< the time budget ran out
  Stagnated,         ///< the method stopped making progress (NSGS: stagnation rule)
  LineSearchFailed,  ///< Newton: no step reduced the merit even with the largest proximal weight
  Diverged,          ///< the forces grew without bound: the problem is likely infeasible
  Outpaced,          ///< Newton: slower than the rival rate it was given (FcNewtonParams::rival_rate)
};

/// A sentence for a stop reason, e.g. "iteration cap reached".
const char* FcStopName(EFcStop stop);

struct FcNewtonParams {
  double tolerance = 1e-6;     ///< on the Siconos error of the original problem
  int max_iterations = 200;    ///< Newton steps (each one LU factorisation)
  double time_budget_s = 0.0;  ///< 0: none
  double sigma0 = 1e-4;        ///< initial proximal weight, relative to the mean diagonal of W
  /// A race (0: none): the rate, in log(error) per second (negative), at which
  /// another method would go on. After `rival_after` steps and rival_grace_s, a
  /// Newton whose own rate since its start (log(best / initial error) over its
  /// time) is slower stops with Outpaced, its best forces in *r.
  double rival_rate = 0.0;
  int rival_after = 3;
  double rival_grace_s = 0.0;
};

struct FcNewtonResult {
  int iterations = 0;         ///< Newton steps taken
  int factorizations = 0;     ///< LU factorisations (a failed one counts)
  double error = 0.0;         ///< Siconos error of the returned forces
  bool converged = false;
  EFcStop stop = EFcStop::IterationCap;
  double sigma = 0.0;         ///< the last proximal weight (absolute)
};

/// One run of the method, a step at a time, so that runs from different starts can
/// be interleaved (fc_fallback.h). Its time budget and race count only the time
/// spent in its own steps.
class FcNewtonRun {
 public:
  /// A run from r0 (zero forces when its size is not 3n). The problem must outlive it.
  FcNewtonRun(const FcProblem& p, const FcNewtonParams& params, const Eigen::VectorXd& r0);
  ~FcNewtonRun();
  FcNewtonRun(const FcNewtonRun&) = delete;
  FcNewtonRun& operator=(const FcNewtonRun&) = delete;

  /// One Newton step (one factorisation); false once the run has ended, its reason
  /// in Result().stop.
  bool Step();
  bool Ended() const { return ended_; }
  /// error: the lowest Siconos error so far (of Best()); converged and stop once ended.
  const FcNewtonResult& Result() const { return res_; }
  const Eigen::VectorXd& Best() const { return best_; }
  double Seconds() const { return seconds_; }

 private:
  struct State;
  bool Finish(EFcStop stop);
  bool Iterate();
  bool LineSearch(double reference, double* t);
  void Restart();

  const FcProblem& p_;
  FcNewtonParams params_;
  std::unique_ptr<State> s_;
  FcNewtonResult res_;
  Eigen::VectorXd best_;
  double start_error_ = 0.0, seconds_ = 0.0, sigma_ = 0.0;
  int since_best_ = 0, monotone_left_ = 0;
  bool ended_ = false;
};

/// Solves from the forces in *r (zeroed when its size is not 3n); leaves the
/// best forces found in *r. Never more than max_iterations factorisations.
FcNewtonResult SolveFcNewton(const FcProblem& p, const FcNewtonParams& params, Eigen::VectorXd* r);

}  // namespace gs
