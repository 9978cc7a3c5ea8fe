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
// Stopping test, on one of two measures (NsgsParams::measure; docs/solver.md):
//  - Siconos' fc3d measure (local_solver.h): sqrt(sum_c |e_c|^2) / max(|q|,|r|,|u|),
//    e_c = r_c - P_K(r_c - u~_c). It adds forces (N) to gaps (m), so the gap error
//    it accepts grows with the forces. Explicit problems (FCLIB files, benches)
//    stop on it, to compare with Siconos.
//  - the scaled measure: the same residual with each force turned into a gap,
//    r~_c = w_c r_c, w_c = W_cc(0,0) (the normal compliance of the contact, m/N),
//    divided by a fixed gap NsgsParams::gap_scale (the step sets |g| dt^2). The
//    cone is invariant under a positive scaling per contact, so (r~, u) is the
//    same problem; scaling every mass by k scales W by 1/k and r by k and leaves
//    r~, u and the measure unchanged. Every contact's gap error per step is then at
//    most tolerance x gap_scale. The simulator's step stops on it.
// Both are computed (NsgsResult::error is the stopping measure, siconos_error
// Siconos'), exactly in a separate pass over the returned forces. A sweep already
// reads every contact's velocity before its local solve, so it accumulates the
// same measures at no cost on the mixed (partly updated) iterate; the exact pass
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

/// What the tolerance is compared with (see above).
enum class EStopMeasure {
  Siconos,  ///< fc3d_compute_error: forces and gaps mixed, relative to max(|q|, |r|, |u|)
  Scaled,   ///< forces as gaps (W_cc(0,0) r_c), absolute, over gap_scale
};

/// The factor that turns contact c's force into a gap (m/N): its normal
/// compliance W_cc(0,0); 0 when that is not a positive finite number.
inline double ForceToGap(const Mat3& W) {
  const double w = W(0, 0);
  return (w > 0.0 && std::isfinite(w)) ? w : 0.0;
}

/// Anderson acceleration's largest depth (NsgsParams::anderson_depth).
constexpr int kAndersonMaxDepth = 8;

struct NsgsParams {
  double tolerance = 1e-6;          ///< on the stopping measure (`measure`)
  EStopMeasure measure = EStopMeasure::Siconos;
  /// m: the denominator of the scaled measure (the step sets |g| dt^2, so that the
  /// tolerance bounds each contact's velocity error by tolerance |g| dt); 1 when not positive
  double gap_scale = 0.0;
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
  /// 2-Lipschitz in r (in r~ = w_c r for the scaled measure: the term is then
  /// 2 |D dr|) and (1 + mu)-Lipschitz in u. The reported error is then that
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
  /// Nonsmooth nonlinear conjugate gradient on top of the sweeps (Silcowitz, Niebe
  /// and Erleben 2010): after a sweep that leaves the forces unconverged, r moves on
  /// by beta times the last direction, beta = |dr_k|^2 / |dr_{k-1}|^2 of the sweeps'
  /// own changes, projected back on each cone; beta > 1 restarts the direction.
  /// Each sweep's local solves stay exact; what the momentum adds is checked by the
  /// same error measure. Costs two copies of r and one more pass over the contacts.
  /// Off for the rest of the solve once it stops paying (ProgressWatch below).
  bool conjugate = false;
  /// Anderson acceleration (0: off): after a sweep that leaves the forces
  /// unconverged, r moves to the combination of the last `anderson_depth` + 1 sweeps'
  /// outputs whose sweep changes (in gap units under the scaled measure) combine to
  /// the least norm, projected back on each cone (class Anderson below). Dense
  /// contacts under a wide skin couple their neighbours at up to 0.9 of their own
  /// compliance (W's condition near 1e5), where plain sweeps gain about 10 % a sweep.
  /// The local solves stay exact and the checked forces are a sweep's own, as with
  /// `conjugate` (which it replaces when both are set).
  int anderson_depth = 0;
};

struct NsgsResult {
  int iterations = 0;
  double error = 0.0;  ///< the stopping measure (NsgsParams::measure) of the returned forces
  /// Siconos' fc3d measure of the same forces (equal to `error` under the Siconos
  /// measure); a bound or an estimate of it with error_bounded / error_estimated
  double siconos_error = 0.0;
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
  /// With `stagnated`: the lowest estimate's fall over the window that fired the
  /// rule (its value at the end over its value at the start; 1: no progress)
  double stall_ratio = 1.0;
};

/// The stagnation rule of NsgsParams, fed the in-sweep estimate of every sweep.
struct NsgsStagnation {
  double best = std::numeric_limits<double>::infinity();
  double best_at_mark = std::numeric_limits<double>::infinity();
  int mark = 0;
  double ratio = 1.0;  ///< best / best_at_mark over the last whole window
  /// True when a whole window passed without the progress the rule asks for.
  bool Stalled(double estimate, int sweep, const NsgsParams& p) {
    if (estimate < best) best = estimate;
    if (p.stagnation_window <= 0 || sweep - mark < p.stagnation_window) return false;
    const bool stalled = mark > 0 && !(best <= p.stagnation_ratio * best_at_mark);
    ratio = mark > 0 && best_at_mark > 0.0 ? std::min(1.0, best / best_at_mark) : 1.0;
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
  std::vector<Vec3> r_prev, direction;            ///< conjugate directions only
  std::vector<double> angle_base, angle_best;     ///< extrapolation only
  /// Anderson acceleration only: the last sweep's output g and change f, and
  /// anderson_depth columns of their differences (column k at [k * n, (k + 1) * n))
  std::vector<Vec3> g_last, f_last, d_g, d_f;
  /// Room for n contacts, with Anderson acceleration of this depth: no solve of up
  /// to n contacts allocates.
  void Reserve(int n, int anderson_depth = 0) {
    angle.reserve(n);
    if (anderson_depth <= 0) return;
    const size_t m = static_cast<size_t>(std::min(anderson_depth, kAndersonMaxDepth));
    r_prev.reserve(n);
    g_last.reserve(n);
    f_last.reserve(n);
    d_g.reserve(m * n);
    d_f.reserve(m * n);
  }
};

inline double SiconosRatio(double num, double nq, double nr, double nu) {
  const double den = std::sqrt(std::max({nq, nr, nu}));
  return den > 2.220446049250313e-16 ? std::sqrt(num) / den : std::sqrt(num);
}

/// The scaled measure's denominator (m).
inline double GapScale(const NsgsParams& p) { return p.gap_scale > 0.0 ? p.gap_scale : 1.0; }

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
  return SiconosRatio(num, op.FreeNormSquared(), nr, nu);
}

/// Both measures of forces r, from one pass.
struct NsgsErrors {
  double stop = 0.0, siconos = 0.0;
};

template <class Op>
NsgsErrors ExactErrors(const Op& op, const Vec3* r, const NsgsParams& p) {
  if (p.measure == EStopMeasure::Siconos) {
    const double e = SiconosError(op, r);
    return {e, e};
  }
  const int n = op.NumContacts();
  double num = 0.0, num_s = 0.0, nr = 0.0, nu = 0.0;
  for (int c = 0; c < n; ++c) {
    const Vec3 u = op.Velocity(c, r);
    const double mu = op.Mu(c);
    num += LocalErrorSquared(r[c], u, mu);
    num_s += LocalErrorSquared(ForceToGap(op.DiagonalBlock(c)) * r[c], u, mu);
    nr += r[c].squaredNorm();
    nu += u.squaredNorm();
  }
  return {std::sqrt(num_s) / GapScale(p), SiconosRatio(num, op.FreeNormSquared(), nr, nu)};
}

/// What a sweep sums on the way: the squared local errors before each update
/// (num; num_s on the scaled forces), |u|^2 as read (nu), |r|^2 after the
/// updates (nr), |dr|^2 of the updates applied (dr2; dr2_s scaled), the trace
/// of W and the largest mu.
struct NsgsSweepSums {
  double num = 0.0, num_s = 0.0, nu = 0.0, nr = 0.0, dr2 = 0.0, dr2_s = 0.0, trace = 0.0, mu_max = 0.0;
};

/// One local update of contact c, added to the sums (the scaled ones when `scaled`).
template <class Op>
inline void NsgsUpdate(Op& op, Vec3* r, int c, double omega, bool scaled, double* angle, NsgsSweepSums* s) {
  const Mat3 W = op.DiagonalBlock(c);
  const Vec3 u = op.Velocity(c, r);
  const double mu = op.Mu(c);
  const double wc = scaled ? ForceToGap(W) : 0.0;
  s->num += LocalErrorSquared(r[c], u, mu);
  if (scaled) s->num_s += LocalErrorSquared(wc * r[c], u, mu);
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
    s->dr2_s += wc * wc * dr.squaredNorm();
  }
  s->nr += r[c].squaredNorm();
}

/// The in-sweep estimates of both measures (on the mixed iterate).
inline NsgsErrors SweepEstimates(const NsgsSweepSums& s, double nq, const NsgsParams& p) {
  const double siconos = SiconosRatio(s.num, nq, s.nr, s.nu);
  if (p.measure == EStopMeasure::Siconos) return {siconos, siconos};
  return {std::sqrt(s.num_s) / GapScale(p), siconos};
}

/// One sweep over the contacts (forward, or backward when `backward`); returns
/// the in-sweep estimates.
template <class Op>
NsgsErrors NsgsSweep(Op& op, Vec3* r, const NsgsParams& p, bool backward, double nq, double* angle,
                     NsgsSweepSums* sums = nullptr) {
  const int n = op.NumContacts();
  const double omega = p.over_relaxation;
  const bool scaled = p.measure == EStopMeasure::Scaled;
  NsgsSweepSums s;
  if (!backward) {
    for (int c = 0; c < n; ++c) NsgsUpdate(op, r, c, omega, scaled, &angle[c], &s);
  } else {
    for (int c = n - 1; c >= 0; --c) NsgsUpdate(op, r, c, omega, scaled, &angle[c], &s);
  }
  if (sums) *sums = s;
  return SweepEstimates(s, nq, p);
}

/// Upper bounds of both exact measures after a sweep with these sums (see
/// NsgsParams::accept_error_bound); infinite when a denominator may vanish.
/// A sweep moves the velocities it read by at most du = |W|_F |dr| <= 2 tr(W) |dr|
/// (the same in both measures: W r = (W D^-1)(D r)); a contact's local error is
/// 2-Lipschitz in its (scaled) force and (1 + mu)-Lipschitz in u.
inline NsgsErrors NsgsErrorBound(const NsgsSweepSums& s, double nq, const NsgsParams& p) {
  const double inf = std::numeric_limits<double>::infinity();
  const double dr = std::sqrt(s.dr2);
  const double du = 2.0 * s.trace * dr;
  const double num = std::sqrt(s.num) + 2.0 * dr + (1.0 + s.mu_max) * du;
  const double den = std::max({std::sqrt(nq), std::sqrt(s.nr), std::sqrt(s.nu) - du});
  const double siconos = (den > 2.220446049250313e-16 && std::isfinite(num)) ? num / den : inf;
  if (p.measure == EStopMeasure::Siconos) return {siconos, siconos};
  const double num_s = std::sqrt(s.num_s) + 2.0 * std::sqrt(s.dr2_s) + (1.0 + s.mu_max) * du;
  return {std::isfinite(num_s) ? num_s / GapScale(p) : inf, siconos};
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
/// ago. Leaves the best candidate in r and returns its exact errors.
template <class Op>
NsgsErrors NsgsExtrapolate(Op& op, Vec3* r, const NsgsParams& p, NsgsScratch& s, double nq, NsgsResult* res) {
  const int n = op.NumContacts();
  s.r_base.assign(r, r + n);
  s.angle_base.assign(s.angle.begin(), s.angle.begin() + n);
  NsgsSweep(op, r, p, false, nq, s.angle.data());
  NsgsErrors best = ExactErrors(op, r, p);
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
    NsgsSweep(op, r, p, false, nq, s.angle.data());
    const NsgsErrors e = ExactErrors(op, r, p);
    ++res->iterations;
    ++res->exact_checks;
    if (e.stop < best.stop) {
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

/// Records errors e in the result (`error` the stopping measure).
inline void SetErrors(NsgsResult* res, const NsgsErrors& e) {
  res->error = e.stop;
  res->siconos_error = e.siconos;
}

// Conjugate directions stay on while they pay: once kMomentumWindow sweeps pass
// without a new lowest estimate and the estimate is above kMomentumRise times that
// lowest, they are off for the rest of the solve. On a pile of 400 boxes (1,617
// contacts) the momentum took the estimate down to 7e-5 in 2,750 sweeps, then
// cycled between 1e-4 and 7e-4 up to the 20,000-sweep cap; plain sweeps from there
// converge. A plateau near the lowest (stacks, before Newton takes over) keeps them.
constexpr int kMomentumWindow = 200;
constexpr double kMomentumRise = 3.0;

/// Turns an acceleration off for the rest of a solve once `window` sweeps pass
/// without a new lowest estimate while the estimate is above `rise` times that lowest.
struct ProgressWatch {
  int window = 0;
  double rise = 0.0;
  double lowest = std::numeric_limits<double>::infinity();
  int lowest_at = 0;
  bool off = false;
  ProgressWatch(int window_sweeps, double rise_factor) : window(window_sweeps), rise(rise_factor) {}
  /// After sweep `sweep` with in-sweep estimate `estimate`: true while the acceleration stays on.
  bool Pays(double estimate, int sweep) {
    if (estimate < lowest) {
      lowest = estimate;
      lowest_at = sweep;
    }
    if (sweep - lowest_at > window && estimate > rise * lowest) off = true;
    return !off;
  }
};

// The conjugate step after a sweep (NsgsParams::conjugate): r_prev holds the forces
// before the sweep, *last the previous sweep's |dr|^2 (0 before the first).
template <class Op>
void ConjugateStep(Op& op, Vec3* r, NsgsScratch& s, int n, double* last) {
  double g2 = 0.0;
  for (int c = 0; c < n; ++c) g2 += (r[c] - s.r_prev[c]).squaredNorm();
  const double beta = *last > 0.0 ? g2 / *last : 0.0;
  *last = g2;
  if (!(beta <= 1.0) || beta == 0.0) {  // first sweep, or a restart
    for (int c = 0; c < n; ++c) s.direction[c] = r[c] - s.r_prev[c];
    return;
  }
  for (int c = 0; c < n; ++c) {
    const Vec3 swept = r[c];
    const Vec3 x = ProjectOntoCone(Vec3(swept + beta * s.direction[c]), op.Mu(c));
    s.direction[c] = (swept - s.r_prev[c]) + beta * s.direction[c];
    if (!x.allFinite()) continue;
    op.ApplyDelta(c, x - swept);
    r[c] = x;
  }
}

// Anderson acceleration (NsgsParams::anderson_depth; Walker and Ni 2011, type II).
// The sweep is a map x -> g(x); its change f = S (g - x) (S: the forces as gaps under
// the scaled measure) vanishes at a solution. With the differences of the last m
// outputs and changes as columns dG, dF, the next forces are g - dG gamma with gamma
// minimising |f - dF gamma| (normal equations of at most m x m, regularised), each
// contact's projected on its cone. A sweep from a combination whose estimate rose
// above its predecessor's clears the history (the combination did not pay), and
// once kAndersonWindow sweeps pass without a new lowest estimate the acceleration
// is off for the rest of the solve (ProgressWatch): at worst the solve goes on as
// plain Gauss-Seidel.
class Anderson {
 public:
  Anderson(NsgsScratch& s, int n, int depth) : s_(s), n_(n), m_(depth) {
    if (depth <= 0) return;
    const size_t need = static_cast<size_t>(n) * static_cast<size_t>(depth);
    if (s.d_g.size() < need) {
      s.d_g.resize(need);
      s.d_f.resize(need);
    }
    if (s.g_last.size() < static_cast<size_t>(n)) {
      s.g_last.resize(n);
      s.f_last.resize(n);
    }
  }
  void Restart() {
    cols_ = next_ = 0;
    have_last_ = combined_ = false;
  }
  /// Whether the forces the last sweep started from were a combination (not a sweep's own).
  bool combined() const { return combined_; }
  /// After a sweep from x to r (the accumulators at r): moves r on. With `scaled`
  /// the changes are weighed in gap units (each contact's ForceToGap), else in forces.
  template <class Op>
  void Step(Op& op, Vec3* r, const Vec3* x, bool scaled) {
    Vec3* dg = s_.d_g.data();
    Vec3* df = s_.d_f.data();
    combined_ = false;
    if (have_last_) {
      // the newest column replaces the oldest (a ring of m columns)
      const int k = next_;
      Vec3* cg = dg + static_cast<size_t>(k) * n_;
      Vec3* cf = df + static_cast<size_t>(k) * n_;
      for (int c = 0; c < n_; ++c) {
        const Vec3 f = Scale(op, c, scaled) * (r[c] - x[c]);
        cf[c] = f - s_.f_last[c];
        cg[c] = r[c] - s_.g_last[c];
        s_.f_last[c] = f;
        s_.g_last[c] = r[c];
      }
      next_ = (next_ + 1) % m_;
      cols_ = std::min(cols_ + 1, m_);
      for (int j = 0; j < cols_; ++j) {
        const double v = Dot(df + static_cast<size_t>(j) * n_, cf);
        gram_(j, k) = gram_(k, j) = v;
      }
    } else {
      for (int c = 0; c < n_; ++c) {
        s_.f_last[c] = Scale(op, c, scaled) * (r[c] - x[c]);
        s_.g_last[c] = r[c];
      }
      have_last_ = true;
      return;
    }
    Combine(op, r, dg, df);
  }

 private:
  static constexpr int kMax = kAndersonMaxDepth;
  template <class Op>
  static double Scale(const Op& op, int c, bool scaled) {
    return scaled ? ForceToGap(op.DiagonalBlock(c)) : 1.0;
  }
  double Dot(const Vec3* a, const Vec3* b) const {
    double v = 0.0;
    for (int c = 0; c < n_; ++c) v += a[c].dot(b[c]);
    return v;
  }
  template <class Op>
  void Combine(Op& op, Vec3* r, const Vec3* dg, const Vec3* df) {
    Eigen::Matrix<double, kMax, kMax> m = gram_;
    Eigen::Matrix<double, kMax, 1> b = Eigen::Matrix<double, kMax, 1>::Zero();
    double trace = 0.0;
    for (int j = 0; j < cols_; ++j) {
      b[j] = Dot(df + static_cast<size_t>(j) * n_, s_.f_last.data());
      trace += m(j, j);
    }
    if (!(trace > 0.0) || !std::isfinite(trace)) return Restart();
    // regularised: a column whose change in f is tiny (forces moving along W's null
    // space, as a box's four corners share its weight) gets no weight
    for (int j = 0; j < cols_; ++j) m(j, j) += 1e-10 * trace;
    const auto mm = m.topLeftCorner(cols_, cols_);
    Eigen::Matrix<double, kMax, 1> gamma = Eigen::Matrix<double, kMax, 1>::Zero();
    SolveSmall(mm, b, &gamma);
    if (!gamma.allFinite()) return Restart();
    combined_ = true;
    for (int c = 0; c < n_; ++c) {
      Vec3 y = r[c];
      for (int j = 0; j < cols_; ++j) y -= gamma[j] * dg[static_cast<size_t>(j) * n_ + c];
      const Vec3 x = ProjectOntoCone(y, op.Mu(c));
      if (!x.allFinite()) continue;
      const Vec3 dr = x - r[c];
      if (dr[0] != 0.0 || dr[1] != 0.0 || dr[2] != 0.0) op.ApplyDelta(c, dr);
      r[c] = x;
    }
  }
  template <class M>
  void SolveSmall(const M& mm, const Eigen::Matrix<double, kMax, 1>& b, Eigen::Matrix<double, kMax, 1>* gamma) const {
    // Cholesky of the regularised Gram matrix, by hand on the fixed-size storage
    Eigen::Matrix<double, kMax, kMax> l = Eigen::Matrix<double, kMax, kMax>::Zero();
    for (int i = 0; i < cols_; ++i)
      for (int j = 0; j <= i; ++j) {
        double v = mm(i, j);
        for (int k = 0; k < j; ++k) v -= l(i, k) * l(j, k);
        if (i == j) {
          if (!(v > 0.0)) {
            gamma->setConstant(NAN);
            return;
          }
          l(i, i) = std::sqrt(v);
        } else {
          l(i, j) = v / l(j, j);
        }
      }
    Eigen::Matrix<double, kMax, 1> y;
    for (int i = 0; i < cols_; ++i) {
      double v = b[i];
      for (int k = 0; k < i; ++k) v -= l(i, k) * y[k];
      y[i] = v / l(i, i);
    }
    for (int i = cols_ - 1; i >= 0; --i) {
      double v = y[i];
      for (int k = i + 1; k < cols_; ++k) v -= l(k, i) * (*gamma)[k];
      (*gamma)[i] = v / l(i, i);
    }
  }

  NsgsScratch& s_;
  int n_, m_;
  int cols_ = 0, next_ = 0;
  bool have_last_ = false, combined_ = false;
  Eigen::Matrix<double, kMax, kMax> gram_ = Eigen::Matrix<double, kMax, kMax>::Zero();
};

// sweeps without a new lowest estimate before the Anderson acceleration is off (ProgressWatch)
constexpr int kAndersonWindow = 100;

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
  const double nq = op.FreeNormSquared();
  const int K = p.extrapolate_every;
  const NsgsBudget budget(p.time_budget_s);
  NsgsStagnation stagnation;
  int sweep = 0;  // plain sweeps
  double last_change = 0.0;  // conjugate: the previous sweep's |dr|^2
  ProgressWatch momentum(kMomentumWindow, kMomentumRise);  // conjugate: on while it pays
  const int depth = std::min(p.anderson_depth, kAndersonMaxDepth);
  const bool conjugate = p.conjugate && depth <= 0;
  if (conjugate || depth > 0) s.r_prev.resize(std::max(s.r_prev.size(), static_cast<size_t>(n)));
  if (conjugate) s.direction.resize(std::max(s.direction.size(), static_cast<size_t>(n)));
  Anderson anderson(s, n, depth);
  ProgressWatch anderson_watch(kAndersonWindow, 0.0);  // on while it finds new lowest estimates
  double last_estimate = std::numeric_limits<double>::infinity();
  while (res.iterations < p.max_iterations) {
    const bool backward = p.order == ESweepOrder::Alternating && (sweep & 1);
    NsgsSweepSums sums;
    if (conjugate || depth > 0) std::copy(r, r + n, s.r_prev.begin());
    const NsgsErrors estimate = NsgsSweep(op, r, p, backward, nq, s.angle.data(), &sums);
    ++sweep;
    ++res.iterations;
    // the momentum only on a sweep that will not be checked: a checked, bounded or
    // estimated error is the error of the forces the sweep left (a solve about to
    // stop at its time budget reports this sweep's forces, and spends no more time)
    const bool out_of_time = budget.Exhausted(res.iterations);
    const bool unchecked = estimate.stop > p.tolerance && res.iterations < p.max_iterations &&
                           !(K > 0 && sweep % K == 0) && !out_of_time;
    if (conjugate && unchecked && momentum.Pays(estimate.stop, res.iterations))
      ConjugateStep(op, r, s, n, &last_change);
    if (depth > 0 && anderson_watch.Pays(estimate.stop, res.iterations) && unchecked) {
      if (anderson.combined() && !(estimate.stop <= last_estimate)) anderson.Restart();
      anderson.Step(op, r, s.r_prev.data(), p.measure == EStopMeasure::Scaled);
    }
    last_estimate = estimate.stop;
    if (p.accept_error_bound && estimate.stop <= p.tolerance) {
      const NsgsErrors bound = NsgsErrorBound(sums, nq, p);
      if (bound.stop <= p.tolerance) {
        SetErrors(&res, bound);
        res.error_bounded = true;
        res.converged = true;
        break;
      }
    }
    if (out_of_time && p.accept_error_bound && estimate.stop > p.tolerance &&
        !budget.HoldsErrorPass(res.iterations)) {
      // out of time even for the exact pass (up to a sweep's cost on a step already
      // late): the sweep's own estimate says how far the forces are
      SetErrors(&res, estimate);
      res.error_estimated = true;
      res.budget_stopped = true;
      break;
    }
    if (estimate.stop <= p.tolerance || res.iterations == p.max_iterations || out_of_time) {
      SetErrors(&res, ExactErrors(op, r, p));
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
    if (stagnation.Stalled(estimate.stop, res.iterations, p)) {
      SetErrors(&res, ExactErrors(op, r, p));
      ++res.exact_checks;
      res.converged = res.error <= p.tolerance;
      res.stagnated = !res.converged;
      res.stall_ratio = stagnation.ratio;
      break;
    }
    if (K <= 0 || sweep % K != 0 || res.iterations >= p.max_iterations) continue;
    if (sweep >= p.extrapolate_after && static_cast<int>(s.r_old.size()) == n) {
      SetErrors(&res, NsgsExtrapolate(op, r, p, s, nq, &res));
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
