// Constrained motion (paper Figure 1, last stage): the solved contact and
// joint-limit forces move the articulations (dq = dq_free + A^-1 sum J^T f,
// already accumulated by the solver) and the control points (u = u_free + sum phi F, eq. 7). A step
// whose result is not finite is undone: the previous configuration is kept and
// the step is reported as rejected.
#include <algorithm>
#include <cmath>

#include "core/world.h"

namespace gs {
namespace {

// the first non-finite value of the step, as a reject reason; null when all are finite
// whether every value is finite: x * 0 is 0 for finite x and NaN for Inf or NaN,
// so one sum tells (a multiply and an add per value, vectorised, instead of a
// per-value classification)
bool AllFinite(const Vec3* v, int n) {
  Vec3 acc = Vec3::Zero();
  for (int j = 0; j < n; ++j) acc += 0.0 * v[j];
  return acc[0] == 0.0 && acc[1] == 0.0 && acc[2] == 0.0;
}

const char* NonFiniteStage(const World& w) {
  for (const Articulation& a : w.articulations)
    if (!a.dq_free.allFinite() || !a.a_inv.allFinite()) return "free motion: not finite";
  for (const Body& b : w.bodies) {
    if (!b.deform.enabled()) continue;
    if (!AllFinite(b.u_free.data(), b.deform.size())) return "free motion: relaxed deformation not finite";
  }
  // one pass over the rows (a contact-space fault is named before a force's)
  // (the same x * 0 sums as AllFinite)
  double space = 0.0, forces = 0.0;
  for (const ContactRow& r : w.rows) {
    space += (0.0 * r.q).sum() + (0.0 * r.w_diag).sum() + (0.0 * r.frame).sum() + 0.0 * r.mu;
    forces += (0.0 * r.r).sum();
  }
  for (const LimitRow& l : w.limit_rows) {
    space += 0.0 * l.q + 0.0 * l.w;
    forces += 0.0 * l.r;
  }
  const bool space_ok = space == 0.0, forces_ok = forces == 0.0;
  if (!space_ok) return "contact space: a contact's gap, frame or Delassus block is not finite";
  if (!forces_ok) return "solve: a contact force is not finite";
  for (const Articulation& a : w.articulations)
    if (!a.dq.allFinite()) return "solve: a contact response is not finite";
  for (const Body& b : w.bodies) {
    if (!b.deform.enabled()) continue;
    if (!AllFinite(b.u_acc.data(), b.deform.size())) return "solve: a contact displacement is not finite";
  }
  return nullptr;
}

// undo: back to the start of the step, deformation untouched
// (the hand and kinematic bodies keep their prescribed poses, which free motion
// has checked finite)
void Undo(World& w) {
  for (Body& b : w.bodies) {
    if (b.motion == EMotion::Free || b.motion == EMotion::Fingertip) b.pose = b.pose_prev;
    b.velocity.setZero();
    b.angular_velocity.setZero();
  }
  for (Finger& f : w.hand.fingers) f.q = f.q_prev;
  for (ContactRow& r : w.rows) r.r.setZero();
  for (LimitRow& l : w.limit_rows) l.r = 0.0;
  // whatever was not finite may sit outside the live points, which the next free
  // motion alone clears: back to exactly at rest everywhere but u
  for (Body& b : w.bodies) {
    std::fill(b.u_free.begin(), b.u_free.end(), Vec3::Zero());
    std::fill(b.u_acc.begin(), b.u_acc.end(), Vec3::Zero());
  }
}

// the articulations' new joints and poses
void MoveArticulations(World& w) {
  const double dt = w.params.dt;
  for (Articulation& a : w.articulations) {
    const Vec6 dq = a.dq_free + a.dq;
    if (a.finger >= 0) {
      // not clamped: the limit rows of the solve hold the joints (core/joint_limits.h);
      // a joint ends past a limit only by the solver's tolerance, or when the step's
      // contacts moved it past a limit farther than joint_limit_margin away, and the
      // next step's row pushes it back (docs/solver.md, "Joint limits")
      Finger& f = w.hand.fingers[a.finger];
      f.q = f.q_prev + dq.head<4>();
      f.kin = FingerForward(f.model, w.hand.pose, f.q);
      ForEachCarried(f, f.kin, [&](int body, const Pose& p) {
        Body& b = w.bodies[body];
        b.pose = p;
        b.velocity = (b.pose.t - b.pose_prev.t) / dt;
      });
    } else {
      Body& b = w.bodies[a.body];
      b.pose = AdvancePose(b.pose_prev, dq);
      // a placement's push-out moved the body without giving it its speed (core/push_out.cpp)
      const Vec6 dv = w.profile.push_out_split ? Vec6(a.dq_free + a.dq_velocity) : dq;
      b.velocity = dv.head<3>() / dt;
      b.angular_velocity = dv.tail<3>() / dt;
    }
  }
}

// a control point's spread (the most its neighbours' displacements differ from its
// own, max over its influence of |u_k - u_j|) is measured again once what it may have
// changed by since its last measure exceeds this fraction of that measure, or this
// fraction of a control-point spacing; until then refit inflates the leaf by the bound
constexpr double kSpreadSlack = 0.1;
constexpr double kSpreadSlackOfSpacing = 0.01;

// eq. 7 on the body's live points (the others are at rest, u = u_free = u_acc = 0,
// and stay unchanged), marking the changed ones for refit; returns the largest change
double IntegrateControlPoints(Body& b) {
  double most2 = 0.0;
  for (int j : b.live) {
    const Vec3 u_new = b.u_free[j] + b.u_acc[j];
    const double d2 = (u_new - b.u[j]).squaredNorm();
    if (d2 > 1e-24) b.u_changed[j] = 1;
    most2 = std::max(most2, d2);
    b.u[j] = u_new;
  }
  return std::sqrt(most2);
}

// what refit needs to know: the spreads of the changed points. Since its last
// measure a spread can have grown by no more than its own point's and a neighbour's
// changes, each at most the body's largest change of a step: twice their sum over
// the steps (spread_slack - spread_mark). Within kSpreadSlack of the measure that
// bound stands for it; past that it is measured (a scan of the point's influence, the
// stage's main cost: every control point of a box the hand lifts moves every step)
void UpdateSpreads(Body& b, double largest_change) {
  b.spread_slack += 2.0 * largest_change;
  const double floor = kSpreadSlackOfSpacing * b.deform.spacing();
  for (int j : b.live) {
    if (!b.u_changed[j]) continue;
    const double slack = b.spread_slack - b.spread_mark[j];
    if (slack <= std::max(kSpreadSlack * b.spread_base[j], floor)) {
      b.u_spread[j] = b.spread_base[j] + slack;
      continue;
    }
    const int* idx;
    const double* phi;
    const int n = b.deform.Influence(j, &idx, &phi);
    // the largest squared distance, one square root
    const Vec3 uj = b.u[j];
    double spread2 = 0.0;
    for (int k = 0; k < n; ++k) spread2 = std::max(spread2, (b.u[idx[k]] - uj).squaredNorm());
    b.u_spread[j] = b.spread_base[j] = std::sqrt(spread2);
    b.spread_mark[j] = b.spread_slack;
  }
}

void MoveControlPoints(World& w) {
  for (Body& b : w.bodies) {
    if (!b.deform.enabled()) continue;
    w.profile.work.deformed_points += static_cast<int>(b.live.size());
    UpdateSpreads(b, IntegrateControlPoints(b));
  }
}

// a pass-through rejects the step, unless the same pair was rejected the last
// pass_through_retries steps in a row: then it is let through (WorldParams)
bool PassThroughRejected(World& w) {
  const PassThrough before = w.last_pass_through;
  if (!FindPassThrough(w)) {
    w.pass_through_streak = 0;
    return false;
  }
  const PassThrough& now = w.last_pass_through;
  const bool same = now.body == before.body && now.other == before.other;
  w.pass_through_streak = same && w.pass_through_streak > 0 ? w.pass_through_streak + 1 : 1;
  if (w.pass_through_streak > w.params.pass_through_retries) {
    ++w.pass_throughs_let;
    w.pass_through_streak = 0;
    return false;
  }
  return true;
}

}  // namespace

void ConstrainedMotion(World& w) {
  if (const char* why = NonFiniteStage(w)) MarkRejected(w, why);
  if (!w.profile.rejected) {
    MoveArticulations(w);
    if (PassThroughRejected(w)) MarkRejected(w, kPassThroughReason);
  }
  if (w.profile.rejected) {
    Undo(w);
  } else {
    MoveControlPoints(w);
  }
  // the end of this step is the start of the next
  for (Body& b : w.bodies) b.pose_prev = b.pose;
  for (Finger& f : w.hand.fingers) f.q_prev = f.q;
  w.hand.pose_prev = w.hand.pose;

  // keep this step's forces (world frame) for the next warm start (the contact space
  // indexes them by key); a rejected step keeps the last accepted step's (its frames
  // may be the non-finite part)
  if (w.profile.rejected) return;
  w.warm_next.clear();
  for (const ContactRow& r : w.rows) w.warm_next.emplace_back(r.contact.key, r.frame.transpose() * r.r);
  std::swap(w.warm_prev, w.warm_next);
  KeepLimitForces(w);
}

}  // namespace gs
