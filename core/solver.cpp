// Solver stage: nonsmooth block Gauss-Seidel over the contacts with the exact
// local Coulomb solve (nsgs.h, local_solver.h), on a matrix-free
// Delassus operator: W = W_rigid + W_deform (eq. 12) is applied through the
// bodies. A change dr of one contact's force moves its articulations'
// accumulators (dq += A^-1 H^T dr) and, for deformable bodies, the control
// points under the force (u_acc += phi F, eq. 13); a contact reads its gap back
// from them. A sweep costs O(contacts x (dof + influence)), never O(contacts^2).
// The joint-limit rows (core/joint_limits.h) follow the contacts in the same
// index space (row rows.size() + k is limit_rows[k]): frictionless rows whose
// force moves a finger's accumulator through A^-1, so every solver path below
// (Gauss-Seidel, normals only, Newton, the assembled problem) solves them with
// the contacts.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/contact_jacobian.h"
#include "core/fc_newton.h"
#include "core/joint_limits.h"
#include "core/local_solver.h"
#include "core/world.h"

namespace gs {
namespace {

class WorldDelassus {
 public:
  explicit WorldDelassus(World& w) : w_(w), contacts_(static_cast<int>(w.rows.size())) {}

  /// contacts, then joint-limit rows
  int NumContacts() const { return contacts_ + static_cast<int>(w_.limit_rows.size()); }
  Mat3 DiagonalBlock(int c) const { return c < contacts_ ? w_.rows[c].w_diag : LimitBlock(Limit(c)); }
  double Mu(int c) const { return c < contacts_ ? w_.rows[c].mu : 0.0; }
  double FreeNormSquared() const {
    double s = 0.0;
    for (const ContactRow& r : w_.rows) s += r.q.squaredNorm();
    for (const LimitRow& l : w_.limit_rows) s += l.q * l.q;
    return s;
  }
  /// The free velocity q of row c and its force as stored in the World.
  Vec3 Free(int c) const { return c < contacts_ ? w_.rows[c].q : Vec3(Limit(c).q, 0.0, 0.0); }
  Vec3 Stored(int c) const { return c < contacts_ ? w_.rows[c].r : Vec3(Limit(c).r, 0.0, 0.0); }
  void Store(int c, const Vec3& r) {
    if (c < contacts_) {
      w_.rows[c].r = r;
    } else {
      w_.limit_rows[c - contacts_].r = r[0];
    }
  }

  // Each side adds to a frame-coordinate term (finger rows) and a world-coordinate
  // term (free bodies' J dq, deformable sides' R d), turned into the frame once.
  Vec3 Velocity(int c, const Vec3* /*r*/) const {
    if (c >= contacts_) return Vec3(LimitVelocity(w_, Limit(c)), 0.0, 0.0);
    return VelocityFrom(c, w_.rows[c].q);
  }
  /// W r alone, without the free velocity q: the columns of an assembled W, exact
  /// (q + W e - q would round W e to q's last bit, and break scale invariance)
  Vec3 Response(int c) const {
    if (c >= contacts_) return Vec3(LimitResponse(w_, Limit(c)), 0.0, 0.0);
    return VelocityFrom(c, Vec3::Zero());
  }
  Vec3 VelocityFrom(int c, const Vec3& q) const {
    const ContactRow& row = w_.rows[c];
    Vec3 u = q, v = Vec3::Zero();
    for (const ContactSide& s : row.side) {
      if (s.articulation >= 0) AddSideVelocity(w_, s, &u, &v);
      if (s.count > 0) v += s.sign * (w_.bodies[s.body].pose.R * Interpolated(s));
    }
    return u + row.frame * v;
  }

  void ApplyDelta(int c, const Vec3& dr) {
    if (c >= contacts_) return PushLimit(w_, Limit(c), dr[0]);  // its tangents carry nothing
    const ContactRow& row = w_.rows[c];
    const Vec3 f = row.frame.transpose() * dr;  // the force on side 0, world
    for (const ContactSide& s : row.side) {
      if (s.articulation >= 0) PushSide(w_, s, dr, f);
      if (s.inf_count > 0) Propagate(s, f);
    }
  }

  // Frictionless contacts carry normal forces only: the normal row of Velocity
  // and a normal ApplyDelta, a third of the work of the 3x6 rows.
  double NormalVelocity(int c) const {
    if (c >= contacts_) return LimitVelocity(w_, Limit(c));
    const ContactRow& row = w_.rows[c];
    double u = row.q[0];
    Vec3 v = Vec3::Zero();
    for (const ContactSide& s : row.side) {
      if (s.articulation >= 0) AddSideNormalVelocity(w_, s, &u, &v);
      if (s.count > 0) v += s.sign * (w_.bodies[s.body].pose.R * Interpolated(s));
    }
    return u + row.frame.row(0).dot(v);
  }

  void ApplyNormalDelta(int c, double dr) {
    if (c >= contacts_) return PushLimit(w_, Limit(c), dr);
    const ContactRow& row = w_.rows[c];
    const Vec3 f = row.frame.row(0).transpose() * dr;
    for (const ContactSide& s : row.side) {
      if (s.articulation >= 0) PushSideNormal(w_, s, dr, f);
      if (s.inf_count > 0) Propagate(s, f);
    }
  }

  int propagations() const { return propagations_; }

 private:
  const LimitRow& Limit(int c) const { return w_.limit_rows[c - contacts_]; }

  // the eq. 8 interpolation of the side's accumulated control-point displacements (rest frame)
  Vec3 Interpolated(const ContactSide& s) const {
    const Vec3* ua = w_.bodies[s.body].u_acc.data();
    Vec3 d = s.w[0] * ua[s.idx[0]];
    for (int k = 1; k < s.count; ++k) d += s.w[k] * ua[s.idx[k]];
    return d;
  }

  // the world force f on side 0 moves the control points under a deformable side
  // (eq. 13): the side's share sign * f, in its body's rest frame, times each influence
  void Propagate(const ContactSide& s, const Vec3& f) {
    Body& b = w_.bodies[s.body];
    const Vec3 fr = s.sign * (b.pose.R.transpose() * f);
    const int* idx = s.inf_idx;
    const double* phi = s.inf_phi;
    Vec3* u = b.u_acc.data();
    for (int m = 0; m < s.inf_count; ++m) u[idx[m]] += phi[m] * fr;
    propagations_ += s.inf_count;
  }

  World& w_;
  int contacts_;  ///< rows.size(): the first limit row's index
  int propagations_ = 0;
};

// Gauss-Seidel on the normal forces alone, for a step whose contacts are all
// frictionless (mu = 0): the cone is the normal half-line, so the exact local
// solve is r_n = max(0, r_n - u_n / W_nn) (what SolveLocalCoulomb does for mu = 0)
// and the tangential forces stay zero. The in-sweep estimates are the measures of
// the normal part (for mu = 0 the tangents add nothing to their numerators, and
// the Siconos denominator here leaves out |u_t|^2, so the estimate is on the safe
// side); the reported errors are the exact measures of the full 3D velocities, as
// in SolveNsgs.
NsgsResult SolveNormalsOnly(WorldDelassus& op, Vec3* r, const NsgsParams& p) {
  NsgsResult res;
  const int n = op.NumContacts();
  const double omega = p.over_relaxation;
  const double nq = op.FreeNormSquared();
  const bool scaled = p.measure == EStopMeasure::Scaled;
  const NsgsBudget budget(p.time_budget_s);
  for (int it = 0; it < p.max_iterations; ++it) {
    NsgsSweepSums s;
    const bool backward = p.order == ESweepOrder::Alternating && (it & 1);
    for (int k = 0; k < n; ++k) {
      const int c = backward ? n - 1 - k : k;
      const double wnn = op.DiagonalBlock(c)(0, 0);
      const double un = op.NormalVelocity(c);
      const double rn = r[c][0];
      const double e = rn - std::max(0.0, rn - un);
      s.num += e * e;
      if (scaled) {
        const double rs = ForceToGap(op.DiagonalBlock(c)) * rn;
        const double es = rs - std::max(0.0, rs - un);
        s.num_s += es * es;
      }
      s.nu += un * un;
      double x = (wnn > 0.0 && std::isfinite(wnn)) ? std::max(0.0, rn - un / wnn) : 0.0;
      if (omega != 1.0) x = std::max(0.0, rn + omega * (x - rn));
      const double dr = x - rn;
      if (std::isfinite(dr)) {
        op.ApplyNormalDelta(c, dr);
        r[c][0] = x;
      }
      s.nr += r[c][0] * r[c][0];
    }
    res.iterations = it + 1;
    const NsgsErrors estimate = SweepEstimates(s, nq, p);
    const bool out_of_time = budget.Exhausted(it + 1);
    if (estimate.stop <= p.tolerance || it + 1 == p.max_iterations || out_of_time) {
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
  }
  return res;
}

// Newton from the forces in *r; when that run ends short of its tolerance, a second
// run from zero forces, kept when clearly better. On the statically indeterminate
// contacts of a heavy box landing on a light one (W of rank 12 against 180 rows), a
// run from the unconverged NSGS forces can stall at its cap where one from zero
// converges (docs/solver.md, "Newton from a second start").
FcNewtonResult NewtonFromTwoStarts(const FcProblem& p, const FcNewtonParams& np, Eigen::VectorXd* r) {
  const FcNewtonResult first = SolveFcNewton(p, np, r);
  if (first.converged) return first;
  Eigen::VectorXd zero = Eigen::VectorXd::Zero(r->size());
  FcNewtonResult second = SolveFcNewton(p, np, &zero);
  // kept when it converged or halved the error: between two near-equal unconverged
  // runs, a last-bit difference (every mass x1000) must not change which one is kept
  if (!(second.converged || second.error < 0.5 * first.error)) return first;
  *r = zero;
  second.iterations += first.iterations;
  second.factorizations += first.factorizations;
  return second;
}

// A step whose NSGS stopped short of the tolerance at its sweep cap (or stalled)
// continues with the proximal semi-smooth Newton method (fc_newton.h) from the
// NSGS forces, on the step's Delassus matrix assembled column by column: Gauss-
// Seidel needs sweeps in proportion to the mass ratio of a heavy body on a light
// one, Newton does not. Under the scaled measure the problem is solved in gap
// units (r~ = w_c r_c: W's columns divided by w_c), whose Siconos error times
// max(|q|, |r~|, |u|) is the scaled measure's numerator, so the tolerance given
// to Newton is the step's, turned into that error. The result is kept only when
// the step's own measure of it is lower; the accumulators then move by the
// difference. Never with a time budget (a factorisation does not fit in a paced
// step), and at most the steps WorldParams::newton_max_work allows; this path allocates (the steady
// state of a converging step never reaches it).
void ContinueWithNewton(World& w, WorldDelassus& op, const NsgsParams& params, NsgsResult* res) {
  const int n = op.NumContacts();
  const int steps = NewtonStepsAllowed(w.params, n);
  if (steps <= 0 || params.time_budget_s > 0.0) return;
  for (int c = 0; c < n; ++c) op.Store(c, w.solve_r[c]);
  FcProblem p;
  Eigen::VectorXd r;
  AssembleContactProblem(w, &p, &r);  // leaves the accumulators at the NSGS forces
  const bool scaled = params.measure == EStopMeasure::Scaled;
  Eigen::VectorXd d = Eigen::VectorXd::Ones(3 * n);
  if (scaled)
    for (int c = 0; c < n; ++c) {
      const double wc = ForceToGap(op.DiagonalBlock(c));
      d.segment<3>(3 * c).setConstant(wc > 0.0 ? wc : 1.0);
    }
  p.W = p.W * d.cwiseInverse().asDiagonal();
  r = r.cwiseProduct(d);
  FcNewtonParams np;
  np.max_iterations = steps;
  np.tolerance = params.tolerance;
  if (scaled) {
    const double den = std::max({p.q.norm(), r.norm(), (p.W * r + p.q).norm(), 1e-300});
    np.tolerance = params.tolerance * GapScale(params) / den;
  }
  const FcNewtonResult nr = NewtonFromTwoStarts(p, np, &r);
  r = r.cwiseQuotient(d);
  std::vector<Vec3>& old = w.solve_r;
  for (int c = 0; c < n; ++c) {
    Vec3 x = ProjectOntoCone(Vec3(r.segment<3>(3 * c)), op.Mu(c));
    if (!x.allFinite()) x = old[c];
    op.ApplyDelta(c, x - old[c]);
    op.Store(c, old[c]);  // the NSGS forces, to go back to
    old[c] = x;
  }
  const NsgsErrors e = ExactErrors(op, w.solve_r.data(), params);
  w.profile.newton_steps = nr.iterations;
  if (e.stop < res->error) {
    res->error = e.stop;
    res->siconos_error = e.siconos;
    res->converged = e.stop <= params.tolerance;
    res->error_bounded = res->error_estimated = false;
    return;
  }
  for (int c = 0; c < n; ++c) {
    op.ApplyDelta(c, op.Stored(c) - w.solve_r[c]);
    w.solve_r[c] = op.Stored(c);
  }
}

}  // namespace

int NewtonStepsAllowed(const WorldParams& wp, int n) {
  if (n <= 0) return 0;
  const double m = 3.0 * n;
  const double per_step = (2.0 / 3.0) * m * m * m;
  return static_cast<int>(std::min<double>(wp.newton_max_steps, std::floor(wp.newton_max_work / per_step)));
}

// what gravity moves a free body in one step
double StepGapScale(const WorldParams& wp) {
  const double g = wp.gravity.norm();
  return ((g > 0.0 && std::isfinite(g)) ? g : 9.81) * wp.dt * wp.dt;
}

void SolveContacts(World& w, bool may_skip) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  WorldDelassus op(w);
  const int n = op.NumContacts();  // contacts and joint-limit rows
  const int contacts = static_cast<int>(w.rows.size());
  w.solve_r.resize(n);
  // every contact frictionless: normals only (their warm start loses its
  // tangential part, which the cone of mu = 0 projects away anyway); the limit
  // rows are frictionless
  bool frictionless = true;
  for (const ContactRow& row : w.rows) frictionless &= (row.mu == 0.0);
  // accumulators start from the warm-start forces, each projected on its cone
  // first (the last step's force may lie outside this step's cone: new frame, new
  // mu), so that a skipped solve moves the bodies with the forces it reports
  for (int c = 0; c < n; ++c) {
    const Vec3 warm = op.Stored(c);
    Vec3 r0 = frictionless ? Vec3(std::max(0.0, warm[0]), 0.0, 0.0) : ProjectOntoCone(warm, op.Mu(c));
    if (!r0.allFinite()) r0.setZero();
    op.Store(c, r0);
    w.solve_r[c] = r0;
    if (r0[0] != 0.0 || r0[1] != 0.0 || r0[2] != 0.0) op.ApplyDelta(c, r0);  // no warm start: nothing to move
  }
  // no time left for one sweep (and the last step did sweep, and nearly every
  // contact has a last force): the warm start stands
  if (n > 0 && may_skip && w.step_budget_s() > 0.0 && w.params.budget_may_skip_solve && w.last_sweep_s_ > 0.0 &&
      !w.last_solve_skipped_ &&
      20 * (contacts - w.profile.work.warm_started) <= contacts) {
    const double spent = std::chrono::duration<double>(t0 - w.step_started()).count();
    const double left = w.step_budget_s() - spent - w.last_constrained_motion_s();
    if (left < w.last_sweep_s_) {
      w.profile.iterations = 0;
      w.profile.residual = 0.0;
      w.profile.residual_siconos = 0.0;
      w.profile.converged = false;
      w.profile.budget_stopped = true;
      w.profile.solve_skipped = true;
      w.last_solve_skipped_ = true;
      w.profile.solve = std::chrono::duration<double>(Clock::now() - t0).count();
      return;
    }
  }
  w.last_solve_skipped_ = false;
  if (n > 0) {
    NsgsParams params = w.params.solver;
    // a step that converged in its sweep may skip the exact error pass (nsgs.h)
    params.accept_error_bound = true;
    params.gap_scale = StepGapScale(w.params);
    if (w.step_budget_s() > 0.0) {
      // what is left of the step's budget once the stages before have run, less what
      // constrained motion took in the last step (at least one sweep always runs)
      const double spent = std::chrono::duration<double>(t0 - w.step_started()).count();
      params.time_budget_s = std::max(1e-9, w.step_budget_s() - spent - w.last_constrained_motion_s());
    }
    NsgsResult res = frictionless ? SolveNormalsOnly(op, w.solve_r.data(), params)
                                        : SolveNsgs(op, w.solve_r.data(), params, w.gs_scratch);
    w.profile.newton_steps = 0;
    if (!res.converged && !res.budget_stopped && w.params.newton_max_steps > 0)
      ContinueWithNewton(w, op, params, &res);
    w.profile.iterations = res.iterations;
    w.profile.residual = res.error;
    w.profile.residual_siconos = res.siconos_error;
    w.profile.converged = res.converged;
    w.profile.budget_stopped = res.budget_stopped;
    w.profile.residual_bounded = res.error_bounded;
    w.profile.residual_estimated = res.error_estimated;
    (frictionless ? w.profile.work.local_solves_normal : w.profile.work.local_solves_3d) += n * res.iterations;
  }
  w.profile.work.propagations += op.propagations();
  for (int c = 0; c < n; ++c) op.Store(c, w.solve_r[c]);
  w.profile.solve = std::chrono::duration<double>(Clock::now() - t0).count();
  if (n > 0 && w.profile.iterations > 0) w.last_sweep_s_ = w.profile.solve / w.profile.iterations;
}

namespace {

void ClearAccumulators(World& w) {
  for (Articulation& a : w.articulations) a.dq.setZero();
  for (Body& b : w.bodies)
    for (Vec3& u : b.u_acc) u.setZero();
}

// The groups through which row c couples to others (out: up to four; returns how
// many): a contact side's body when it deforms, its articulation when it moves
// (index bodies + articulation: a finger's bodies all move its one articulation);
// a limit row's articulation.
int CouplingGroups(const World& w, int c, int out[4]) {
  const int contacts = static_cast<int>(w.rows.size());
  const int bodies = static_cast<int>(w.bodies.size());
  if (c >= contacts) {
    out[0] = bodies + w.limit_rows[c - contacts].articulation;
    return 1;
  }
  int k = 0;
  for (const ContactSide& s : w.rows[c].side) {
    if (s.inf_count > 0) out[k++] = s.body;
    if (s.articulation >= 0) out[k++] = bodies + s.articulation;
  }
  return k;
}

}  // namespace

void AssembleContactProblem(World& w, FcProblem* p, Eigen::VectorXd* r) {
  WorldDelassus op(w);
  const int n = op.NumContacts();  // contacts, then joint-limit rows
  p->contacts = n;
  p->q.resize(3 * n);
  p->mu.resize(n);
  if (r) r->resize(3 * n);
  for (int c = 0; c < n; ++c) {
    p->q.segment<3>(3 * c) = op.Free(c);
    p->mu[c] = op.Mu(c);
    if (r) r->segment<3>(3 * c) = op.Stored(c);
  }
  // rows grouped by the bodies (or fingers) through which they couple
  std::vector<std::vector<int>> by_group(w.bodies.size() + w.articulations.size());
  int groups[4];
  for (int c = 0; c < n; ++c)
    for (int k = CouplingGroups(w, c, groups); k-- > 0;) by_group[groups[k]].push_back(c);
  ClearAccumulators(w);
  std::vector<Eigen::Triplet<double>> trip;
  std::vector<int> mark(n, -1), touched;
  for (int c = 0; c < n; ++c) {
    touched.clear();
    for (int k = CouplingGroups(w, c, groups); k-- > 0;)
      for (int d : by_group[groups[k]])
        if (mark[d] != c) {
          mark[d] = c;
          touched.push_back(d);
        }
    std::sort(touched.begin(), touched.end());
    for (int k = 0; k < 3; ++k) {
      const Vec3 e = Vec3::Unit(k);
      op.ApplyDelta(c, e);
      for (int d : touched) {
        const Vec3 col = op.Response(d);
        for (int i = 0; i < 3; ++i)
          if (col[i] != 0.0) trip.emplace_back(3 * d + i, 3 * c + k, col[i]);
      }
      ClearAccumulators(w);
    }
  }
  p->W.resize(3 * n, 3 * n);
  p->W.setFromTriplets(trip.begin(), trip.end());
  p->W.makeCompressed();
  // back to the accumulators of the step's forces
  for (int c = 0; c < n; ++c) op.ApplyDelta(c, op.Stored(c));
}

}  // namespace gs
