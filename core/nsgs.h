// Nonsmooth block Gauss-Seidel (NSGS) over the contacts, each 3x3 local
// Coulomb problem solved exactly (local_solver.h), on any Delassus operator
// seen contact by contact:
//   int  NumContacts() const;
//   Mat3 DiagonalBlock(int c) const;            W_cc
//   Vec3 Velocity(int c, const Vec3* r) const;  u_c = q_c + sum_j W_cj r_j (own term included)
//   void ApplyDelta(int c, const Vec3& dr);     r_c changed by dr
//   double Mu(int c) const;
//   double FreeNormSquared() const;             |q|^2 over all contacts
//
// Stopping test. The reported error is Siconos' fc3d measure (local_solver.h) of
// the returned forces, computed exactly in a separate pass. A sweep already
// reads every contact's velocity before its local solve, so it accumulates the
// same measure at no cost on the mixed (partly updated) iterate; the exact pass
// runs only when that estimate says the tolerance may be met, and on the last
// sweep. The in-sweep estimate tracks the exact error within a small factor.
//
// Options: over-relaxation (r <- P_K(r + omega (r_local - r))), and the sweep
// order: forward, or alternating forward/backward (symmetric Gauss-Seidel),
// which damps the order-dependent cycles plain forward sweeps fall into on
// strongly coupled problems.
// Extrapolation (off by default; SolveFcProblem turns it on): on statically
// indeterminate problems (several contacts holding one body, W singular, r not
// unique) Gauss-Seidel drifts slowly along the solution set for thousands of
// sweeps, or cycles between a few contact states. Every `extrapolate_every`
// sweeps (from `extrapolate_after` on) the drift of the last period, d = r -
// r_old, is followed: r + beta d projected on the cones, for beta in 16, 4, 1,
// each followed by one sweep and an exact error check, against one plain sweep
// from r; the lowest error wins (so a bad guess costs sweeps, never accuracy).
// Nothing is allocated when the scratch has room for the contacts.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "core/local_solver.h"

namespace gs {

enum class ESweepOrder { Forward, Alternating };

struct NsgsParams {
  double tolerance = 1e-6;          ///< on the Siconos error
  int max_iterations = 100;         ///< sweeps
  double over_relaxation = 1.0;     ///< omega: r <- r + omega (r_local - r), then projected on the cone
  ESweepOrder order = ESweepOrder::Forward;
  int extrapolate_every = 0;        ///< K: sweeps between extrapolation trials (0: never)
  int extrapolate_after = 100;      ///< first trial after this many sweeps
  /// Wall-clock budget of the solve (s; 0: none). The solver stops sweeping when one
  /// more sweep and the exact error pass would not fit in it, runs that pass and
  /// reports the error reached, with `budget_stopped` set (at least one sweep always
  /// runs). For loops paced by the wall clock (live, bench realtime): a run with a
  /// budget depends on the machine's speed, so run and replay never set one.
  double time_budget_s = 0.0;
  /// Accept a converged sweep without the exact error pass when a bound of the
  /// exact error already meets the tolerance: the in-sweep estimate (on the mixed
  /// iterate) plus what the sweep's own force changes dr can have moved it, from
  /// |u_final - u_read| <= |W|_F |dr| <= 2 tr(W) |dr| (W positive semi-definite;
  /// the factor 2 covers the truncated kernel) and the local error being
  /// 2-Lipschitz in r and (1 + mu)-Lipschitz in u. The reported error is then that
  /// bound, at least the exact error (`error_bounded`). A step at rest (dr ~ 0)
  /// saves its exact pass, a third of its solve. A solve stopped by its time budget
  /// with no time left for the exact pass either skips it and reports the in-sweep
  /// estimate, unconverged (`error_estimated`; the bound, loose while the forces
  /// still move, would say little). Off for explicit problems (files,
  /// benches), whose reported error is the exact one; the simulator's step sets it.
  bool accept_error_bound = false;
  /// Stagnation rule (0: off): every `stagnation_window` sweeps the lowest in-sweep
  /// estimate so far must have fallen below `stagnation_ratio` times its value a
  /// window earlier; otherwise the solve stops after an exact error pass with
  /// `stagnated` set, so that a second method can continue from the forces.
  int stagnation_window = 0;
  double stagnation_ratio = 0.5;
};

struct NsgsResult {
  int iterations = 0;
  double error = 0.0;  ///< Siconos fc3d error of the returned forces
  bool converged = false;
  int exact_checks = 0;  ///< exact error passes
  int extrapolations = 0;  ///< extrapolation trials that won
  bool budget_stopped = false;  ///< stopped by the time budget before the tolerance was met
  bool error_bounded = false;   ///< `error` is an upper bound of the exact error (accept_error_bound)
  /// `error` is the last sweep's in-sweep estimate (a solve stopped by its budget,
  /// with no time for the exact pass, under accept_error_bound): the error of the
  /// mixed iterate the sweep read, not a bound
  bool error_estimated = false;
  bool stagnated = false;  ///< stopped by the stagnation rule (NsgsParams::stagnation_window)
};

/// The stagnation rule of NsgsParams, fed the in-sweep estimate of every sweep.
struct NsgsStagnation {
  double best = std::numeric_limits<double>::infinity();
  double best_at_mark = std::numeric_limits<double>::infinity();
  int mark = 0;
  /// True when a whole window passed without the progress the rule asks for.
  bool Stalled(double estimate, int sweep, const NsgsParams& p) {
    if (estimate < best) best = estimate;
    if (p.stagnation_window <= 0 || sweep - mark < p.stagnation_window) return false;
    const bool stalled = mark > 0 && !(best <= p.stagnation_ratio * best_at_mark);
    best_at_mark = best;
    mark = sweep;
    return stalled;
  }
};

/// The time budget of NsgsParams: the solve's start time and the rule that ends it.
class NsgsBudget {
 public:
  explicit NsgsBudget(double budget_s) : budget_s_(budget_s), t0_(std::chrono::steady_clock::now()) {}
  /// After `sweeps` sweeps: true when one more sweep and an exact error pass (about
  /// one sweep's cost) would overrun the budget.
  bool Exhausted(int sweeps) const {
    if (budget_s_ <= 0.0 || sweeps <= 0) return false;
    const double spent = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    return spent + 2.0 * spent / sweeps > budget_s_;
  }
  /// After `sweeps` sweeps: true when an exact error pass alone (at most one sweep's
  /// cost) still fits in the budget.
  bool HoldsErrorPass(int sweeps) const {
    if (budget_s_ <= 0.0 || sweeps <= 0) return true;
    const double spent = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    return spent + spent / sweeps <= budget_s_;
  }

 private:
  double budget_s_;
  std::chrono::steady_clock::time_point t0_;
};

struct NsgsScratch {
  std::vector<double> angle;  ///< per-contact slip angle hints
  std::vector<Vec3> r_old, r_base, r_best;        ///< extrapolation only
  std::vector<double> angle_base, angle_best;     ///< extrapolation only
  void Reserve(int n) { angle.reserve(n); }
};

/// The Siconos error of forces r (u recomputed through the operator).
template <class Op>
double SiconosError(const Op& op, const Vec3* r) {
  const int n = op.NumContacts();
  double num = 0.0, nr = 0.0, nu = 0.0;
  for (int c = 0; c < n; ++c) {
    const Vec3 u = op.Velocity(c, r);
    num += LocalErrorSquared(r[c], u, op.Mu(c));
    nr += r[c].squaredNorm();
    nu += u.squaredNorm();
  }
  const double nq = op.FreeNormSquared();
  const double den = std::sqrt(std::max({nq, nr, nu}));
  return den > 2.220446049250313e-16 ? std::sqrt(num) / den : std::sqrt(num);
}

/// What a sweep sums on the way: the squared local errors before each update
/// (num), |u|^2 as read (nu), |r|^2 after the updates (nr), |dr|^2 of the updates
/// applied, the trace of W and the largest mu.
struct NsgsSweepSums {
  double num = 0.0, nu = 0.0, nr = 0.0, dr2 = 0.0, trace = 0.0, mu_max = 0.0;
};

/// One local update of contact c, added to the sums.
template <class Op>
inline void NsgsUpdate(Op& op, Vec3* r, int c, double omega, double* angle, NsgsSweepSums* s) {
  const Mat3 W = op.DiagonalBlock(c);
  const Vec3 u = op.Velocity(c, r);
  const double mu = op.Mu(c);
  s->num += LocalErrorSquared(r[c], u, mu);
  s->nu += u.squaredNorm();
  s->trace += W.trace();
  s->mu_max = std::max(s->mu_max, mu);
  const Vec3 q_local = u - W * r[c];
  Vec3 x;
  SolveLocalCoulomb(W, q_local, mu, &x, angle);
  if (omega != 1.0) x = ProjectOntoCone(r[c] + omega * (x - r[c]), mu);
  const Vec3 dr = x - r[c];
  if (dr.allFinite()) {
    // an unchanged force (a contact that stays open) moves nothing
    if (dr[0] != 0.0 || dr[1] != 0.0 || dr[2] != 0.0) op.ApplyDelta(c, dr);
    r[c] = x;
    s->dr2 += dr.squaredNorm();
  }
  s->nr += r[c].squaredNorm();
}

/// One sweep over the contacts (forward, or backward when `backward`); returns
/// the in-sweep estimate of the Siconos error (on the mixed iterate).
template <class Op>
double NsgsSweep(Op& op, Vec3* r, double omega, bool backward, double nq, double* angle,
                 NsgsSweepSums* sums = nullptr) {
  const int n = op.NumContacts();
  NsgsSweepSums s;
  if (!backward) {
    for (int c = 0; c < n; ++c) NsgsUpdate(op, r, c, omega, &angle[c], &s);
  } else {
    for (int c = n - 1; c >= 0; --c) NsgsUpdate(op, r, c, omega, &angle[c], &s);
  }
  if (sums) *sums = s;
  const double den = std::sqrt(std::max({nq, s.nr, s.nu}));
  return den > 2.220446049250313e-16 ? std::sqrt(s.num) / den : std::sqrt(s.num);
}

/// An upper bound of the exact Siconos error after a sweep with these sums (see
/// NsgsParams::accept_error_bound); infinite when the denominator may vanish.
inline double NsgsErrorBound(const NsgsSweepSums& s, double nq) {
  const double dr = std::sqrt(s.dr2);
  const double du = 2.0 * s.trace * dr;
  const double num = std::sqrt(s.num) + 2.0 * dr + (1.0 + s.mu_max) * du;
  const double den = std::max({std::sqrt(nq), std::sqrt(s.nr), std::sqrt(s.nu) - du});
  if (!(den > 2.220446049250313e-16) || !std::isfinite(num)) return std::numeric_limits<double>::infinity();
  return num / den;
}

/// Sets the forces to x through the operator.
template <class Op>
inline void NsgsAssign(Op& op, Vec3* r, const Vec3* x) {
  const int n = op.NumContacts();
  for (int c = 0; c < n; ++c) {
    const Vec3 dr = x[c] - r[c];
    if (dr[0] != 0.0 || dr[1] != 0.0 || dr[2] != 0.0) op.ApplyDelta(c, dr);
    r[c] = x[c];
  }
}

/// One extrapolation trial (see above) from r, with r_old the forces K sweeps
/// ago. Leaves the best candidate in r and returns its exact error.
template <class Op>
double NsgsExtrapolate(Op& op, Vec3* r, const NsgsParams& p, NsgsScratch& s, double nq, NsgsResult* res) {
  const int n = op.NumContacts();
  s.r_base.assign(r, r + n);
  s.angle_base.assign(s.angle.begin(), s.angle.begin() + n);
  NsgsSweep(op, r, p.over_relaxation, false, nq, s.angle.data());
  double best = SiconosError(op, r);
  ++res->iterations;
  ++res->exact_checks;
  s.r_best.assign(r, r + n);
  s.angle_best.assign(s.angle.begin(), s.angle.begin() + n);
  bool won = false;
  for (const double beta : {16.0, 4.0, 1.0}) {
    if (res->iterations >= p.max_iterations) break;
    for (int c = 0; c < n; ++c) {
      Vec3 x = ProjectOntoCone(s.r_base[c] + beta * (s.r_base[c] - s.r_old[c]), op.Mu(c));
      if (!x.allFinite()) x = s.r_base[c];
      const Vec3 dr = x - r[c];
      op.ApplyDelta(c, dr);
      r[c] = x;
    }
    std::copy(s.angle_base.begin(), s.angle_base.end(), s.angle.begin());
    NsgsSweep(op, r, p.over_relaxation, false, nq, s.angle.data());
    const double e = SiconosError(op, r);
    ++res->iterations;
    ++res->exact_checks;
    if (e < best) {
      best = e;
      won = true;
      std::copy(r, r + n, s.r_best.begin());
      std::copy(s.angle.begin(), s.angle.begin() + n, s.angle_best.begin());
    }
  }
  NsgsAssign(op, r, s.r_best.data());
  std::copy(s.angle_best.begin(), s.angle_best.end(), s.angle.begin());
  if (won) ++res->extrapolations;
  return best;
}

template <class Op>
NsgsResult SolveNsgs(Op& op, Vec3* r, const NsgsParams& p, NsgsScratch& s) {
  NsgsResult res;
  const int n = op.NumContacts();
  if (n == 0) {
    res.converged = true;
    return res;
  }
  if (static_cast<int>(s.angle.size()) < n) s.angle.resize(n, NAN);
  std::fill(s.angle.begin(), s.angle.begin() + n, NAN);
  s.r_old.clear();
  const double omega = p.over_relaxation;
  const double nq = op.FreeNormSquared();
  const int K = p.extrapolate_every;
  const NsgsBudget budget(p.time_budget_s);
  NsgsStagnation stagnation;
  int sweep = 0;  // plain sweeps
  while (res.iterations < p.max_iterations) {
    const bool backward = p.order == ESweepOrder::Alternating && (sweep & 1);
    NsgsSweepSums sums;
    const double estimate = NsgsSweep(op, r, omega, backward, nq, s.angle.data(), &sums);
    ++sweep;
    ++res.iterations;
    if (p.accept_error_bound && estimate <= p.tolerance) {
      const double bound = NsgsErrorBound(sums, nq);
      if (bound <= p.tolerance) {
        res.error = bound;
        res.error_bounded = true;
        res.converged = true;
        break;
      }
    }
    const bool out_of_time = budget.Exhausted(res.iterations);
    if (out_of_time && p.accept_error_bound && estimate > p.tolerance && !budget.HoldsErrorPass(res.iterations)) {
      // out of time even for the exact pass (up to a sweep's cost on a step already
      // late): the sweep's own estimate says how far the forces are
      res.error = estimate;
      res.error_estimated = true;
      res.budget_stopped = true;
      break;
    }
    if (estimate <= p.tolerance || res.iterations == p.max_iterations || out_of_time) {
      res.error = SiconosError(op, r);
      ++res.exact_checks;
      if (res.error <= p.tolerance) {
        res.converged = true;
        break;
      }
      if (out_of_time) {
        res.budget_stopped = true;
        break;
      }
    }
    if (stagnation.Stalled(estimate, res.iterations, p)) {
      res.error = SiconosError(op, r);
      ++res.exact_checks;
      res.converged = res.error <= p.tolerance;
      res.stagnated = !res.converged;
      break;
    }
    if (K <= 0 || sweep % K != 0 || res.iterations >= p.max_iterations) continue;
    if (sweep >= p.extrapolate_after && static_cast<int>(s.r_old.size()) == n) {
      res.error = NsgsExtrapolate(op, r, p, s, nq, &res);
      if (res.error <= p.tolerance) {
        res.converged = true;
        break;
      }
    }
    s.r_old.assign(r, r + n);
  }
  return res;
}

}  // namespace gs
