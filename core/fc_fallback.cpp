#include "core/fc_fallback.h"

#include <chrono>
#include <cmath>
#include <cstdio>

namespace gs {

const char* FcMethodName(EFcMethod m) {
  switch (m) {
    case EFcMethod::Nsgs: return "nsgs";
    case EFcMethod::Newton: return "newton";
    case EFcMethod::Auto: return "auto";
  }
  return "unknown";
}

std::string FcMethodResult::Summary() const {
  char buf[320];
  std::snprintf(buf, sizeof buf, "%s: NSGS %d sweeps%s (%.3f ms), Newton %d steps, %d factorisations (%.3f ms), error %.3e, %s",
                FcMethodName(method), nsgs.iterations,
                nsgs_resumed ? (newton_rerun ? " (resumed after Newton, stalled again)" : " (resumed after Newton)")
                : nsgs.stagnated ? " until stagnation" : "",
                1e3 * nsgs_seconds, newton.iterations, newton.factorizations, 1e3 * newton_seconds, error,
                FcStopName(stop));
  return buf;
}

namespace {

// auto: races of Newton against NSGS's pace before NSGS goes on without its rule
constexpr int kRaces = 3;

double Since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// NSGS from *r; the stagnation rule only in auto's first stage
void RunNsgs(const FcProblem& p, bool stagnation_rule, int max_sweeps, const FcMethodParams& params,
             double budget, Eigen::VectorXd* r, FcMethodResult* out) {
  const auto t0 = std::chrono::steady_clock::now();
  FcSolveParams sp;
  sp.nsgs.tolerance = params.tolerance;
  sp.nsgs.max_iterations = max_sweeps;
  sp.nsgs.over_relaxation = params.over_relaxation;
  sp.nsgs.order = params.order;
  sp.nsgs.extrapolate_every = params.extrapolate_every;
  sp.nsgs.time_budget_s = budget;
  if (stagnation_rule) {
    sp.nsgs.stagnation_window = params.stagnation_window;
    sp.nsgs.stagnation_ratio = params.stagnation_ratio;
  }
  const int before = out->nsgs.iterations;
  out->nsgs = SolveFcProblem(p, sp, r).nsgs;
  out->nsgs.iterations += before;
  out->nsgs_seconds += Since(t0);
  out->error = out->nsgs.error;
  out->converged = out->nsgs.converged;
  out->stop = out->nsgs.converged        ? EFcStop::Converged
              : out->nsgs.stagnated      ? EFcStop::Stagnated
              : out->nsgs.budget_stopped ? EFcStop::TimeCap
                                         : EFcStop::IterationCap;
}

// NSGS's pace when its stagnation rule fired: the rate of its error, in
// log(error) per second, over the window that fired it (0: no progress)
double NsgsRate(const FcMethodResult& out, const FcMethodParams& params) {
  const double ratio = out.nsgs.stall_ratio;
  if (!(ratio < 1.0) || !(ratio > 0.0) || out.nsgs.iterations <= 0 || !(out.nsgs_seconds > 0.0)) return 0.0;
  return std::log(ratio) / (params.stagnation_window * out.nsgs_seconds / out.nsgs.iterations);
}

FcNewtonParams NewtonParams(const FcMethodParams& params, double budget, double rival_rate, double from_error) {
  FcNewtonParams np;
  np.tolerance = params.tolerance;
  np.max_iterations = params.max_newton;
  np.time_budget_s = budget;
  if (rival_rate < 0.0) {
    // Newton's first steps are its slowest (proximal, far from the solution): it is
    // judged after a tenth of the time NSGS would still need at its pace
    np.rival_rate = rival_rate;
    np.rival_grace_s = 0.1 * std::log(params.tolerance / std::max(from_error, params.tolerance)) / rival_rate;
  }
  return np;
}

void RunNewton(const FcProblem& p, const FcMethodParams& params, double budget, double rival_rate,
               Eigen::VectorXd* r, FcMethodResult* out) {
  const auto t0 = std::chrono::steady_clock::now();
  out->newton = SolveFcNewton(p, NewtonParams(params, budget, rival_rate, out->error), r);
  out->newton_ran = true;
  out->newton_seconds = Since(t0);
  out->error = out->newton.error;
  out->converged = out->newton.converged;
  out->stop = out->newton.stop;
}

// The stop of two runs that ended together: converged if one did; diverged if one
// did; outpaced only if both were; else the reason of the one not outpaced
EFcStop CombinedStop(const FcNewtonResult& a, const FcNewtonResult& b) {
  if (a.converged || b.converged) return EFcStop::Converged;
  if (a.stop == EFcStop::Diverged || b.stop == EFcStop::Diverged) return EFcStop::Diverged;
  if (a.stop == EFcStop::TimeCap || b.stop == EFcStop::TimeCap) return EFcStop::TimeCap;
  return a.stop == EFcStop::Outpaced ? b.stop : a.stop;
}

// auto's first Newton stage: one run from NSGS's forces *r and one from the forces
// the solve started from, interleaved (the run that has spent less time steps
// next) until one converges or both end; *r gets the better run's best forces. A
// Newton started from NSGS's stalled forces can crawl where one from the start does
// not (a 10-box stack at mass ratio 100: 200 steps unconverged against 24), and
// the other way round (a pile of 12 boxes: 13 steps against 54); the pair costs
// at most twice the better one.
void RunNewtonPair(const FcProblem& p, const FcMethodParams& params, double budget, double rival_rate,
                   const Eigen::VectorXd& start, Eigen::VectorXd* r, FcMethodResult* out) {
  const auto t0 = std::chrono::steady_clock::now();
  const FcNewtonParams np = NewtonParams(params, budget, rival_rate, out->error);
  FcNewtonRun warm(p, np, *r), cold(p, np, start);
  while (!warm.Ended() || !cold.Ended()) {
    FcNewtonRun& next = cold.Ended() || (!warm.Ended() && warm.Seconds() <= cold.Seconds()) ? warm : cold;
    next.Step();
    if (next.Result().converged) break;
    if (budget > 0.0 && Since(t0) > budget) break;
  }
  const FcNewtonRun& better = cold.Result().error < warm.Result().error ? cold : warm;
  *r = better.Best();
  out->newton = better.Result();
  out->newton.iterations = warm.Result().iterations + cold.Result().iterations;
  out->newton.factorizations = warm.Result().factorizations + cold.Result().factorizations;
  out->newton.stop = warm.Ended() && cold.Ended() ? CombinedStop(warm.Result(), cold.Result())
                     : better.Result().converged ? EFcStop::Converged
                                                 : EFcStop::TimeCap;
  out->newton.converged = out->newton.stop == EFcStop::Converged;
  out->newton_ran = true;
  out->newton_seconds = Since(t0);
  out->error = out->newton.error;
  out->converged = out->newton.converged;
  out->stop = out->newton.stop;
}

// auto, a resumed NSGS stalled again: Newton races its new pace from its forces,
// counted with the earlier Newton runs; NSGS's forces stay when Newton ends no better
void RaceNewtonAgain(const FcProblem& p, const FcMethodParams& params, double budget, Eigen::VectorXd* r,
                     FcMethodResult* out, bool race = true) {
  const Eigen::VectorXd from_nsgs = *r;
  const double nsgs_error = out->error;
  const FcNewtonResult before = out->newton;
  const double before_seconds = out->newton_seconds;
  RunNewton(p, params, budget, race ? NsgsRate(*out, params) : 0.0, r, out);
  out->newton_rerun = true;
  out->newton.iterations += before.iterations;
  out->newton.factorizations += before.factorizations;
  out->newton_seconds += before_seconds;
  if (!(out->error < nsgs_error)) {
    *r = from_nsgs;
    out->error = nsgs_error;
  }
}

// True when r "solves" p only because |r| is huge: the relative error is small, but
// |r| mean(diag W) exceeds 1e4 |q| and the error relative to |q| alone is not. An
// infeasible problem (a body squeezed between two closing walls) gives this: the
// forces grow without bound while their relative error falls.
bool UnboundedForces(const FcProblem& p, const Eigen::VectorXd& r, double tolerance) {
  const double q = p.q.norm(), diag = p.W.diagonal().mean();
  if (!(r.norm() * diag > 1e4 * q)) return false;
  const Eigen::VectorXd u = p.W * r + p.q;
  double num = 0.0;
  for (int c = 0; c < p.contacts; ++c) num += LocalErrorSquared(r.segment<3>(3 * c), u.segment<3>(3 * c), p.mu[c]);
  return std::sqrt(num) > tolerance * std::max(q, 2.220446049250313e-16);
}

}  // namespace

FcMethodResult SolveFcMethod(const FcProblem& p, EFcMethod method, const FcMethodParams& params,
                             Eigen::VectorXd* r) {
  const auto t0 = std::chrono::steady_clock::now();
  FcMethodResult out;
  out.method = method;
  if (r->size() != 3 * p.contacts) r->setZero(3 * p.contacts);
  const Eigen::VectorXd start = *r;
  const auto left = [&] { return params.time_budget_s > 0.0 ? params.time_budget_s - Since(t0) : 0.0; };
  const auto budget_left = [&] { return params.time_budget_s <= 0.0 || Since(t0) < params.time_budget_s; };
  if (method != EFcMethod::Newton)
    RunNsgs(p, method == EFcMethod::Auto, params.max_sweeps, params, params.time_budget_s, r, &out);
  if (method == EFcMethod::Newton || (method == EFcMethod::Auto && !out.converged && budget_left())) {
    const Eigen::VectorXd from_nsgs = *r;
    const double nsgs_error = out.error;
    // auto races Newton against the pace NSGS had when it was stopped
    const double rival = method == EFcMethod::Auto && out.nsgs.stagnated ? NsgsRate(out, params) : 0.0;
    if (method == EFcMethod::Auto)
      RunNewtonPair(p, params, left(), rival, start, r, &out);
    else
      RunNewton(p, params, left(), rival, r, &out);
    if (method == EFcMethod::Auto && out.newton_ran && !(out.error < nsgs_error)) {
      *r = from_nsgs;  // Newton found nothing better: keep NSGS's forces, and Newton's stop reason
      out.error = nsgs_error;
    }
    // NSGS was converging faster: it goes on from the better forces under its
    // stagnation rule; stalled again, Newton races its new pace (a stall with no
    // progress, where Newton is needed, gives a pace near 0); after kRaces races
    // NSGS goes on without the rule, to its cap
    for (int race = 1; out.stop == EFcStop::Outpaced && out.nsgs.iterations < params.max_sweeps && budget_left();
         ++race) {
      out.nsgs_resumed = true;
      RunNsgs(p, race < kRaces, params.max_sweeps - out.nsgs.iterations, params, left(), r, &out);
      if (out.converged || !out.nsgs.stagnated || !budget_left()) break;
      RaceNewtonAgain(p, params, left(), r, &out);
    }
    // Newton ended at its own cap (or its line search failed): NSGS goes on from the
    // best forces without the rule, to its cap, so that auto never ends short of
    // where NSGS alone would have gone (a 500-contact random stack fired the rule at
    // 600 sweeps and left Newton at 1.3e-6 after its 200 steps)
    if (method == EFcMethod::Auto && !out.converged && out.stop != EFcStop::Outpaced &&
        out.stop != EFcStop::TimeCap && out.stop != EFcStop::Diverged && out.nsgs.iterations < params.max_sweeps &&
        budget_left()) {
      out.nsgs_resumed = true;
      RunNsgs(p, false, params.max_sweeps - out.nsgs.iterations, params, left(), r, &out);
    }
  }
  // NSGS ended at its cap after Newton lost a race: a race is decided on time, and on a
  // busy machine Newton can lose one it would have won (a 10-box stack at mass ratio
  // 1,000 then ended at 2.9e-6 after 20,000 sweeps where Newton from the same forces
  // converges): Newton goes on from the forces, without the race, to its own cap
  if (method == EFcMethod::Auto && !out.converged && out.stop == EFcStop::IterationCap && out.newton_ran &&
      budget_left())
    RaceNewtonAgain(p, params, left(), r, &out, false);
  if (out.converged && UnboundedForces(p, *r, params.tolerance)) {
    out.converged = false;
    out.stop = EFcStop::Diverged;
  }
  out.seconds = Since(t0);
  return out;
}

}  // namespace gs
