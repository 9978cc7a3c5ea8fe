// Push-out without speed: an overlap already present at the start of a step between
// two rigid surfaces (a body placed inside another's MLS surface, a teleport, a
// control point of a rolling sampled ball turned under a plane) is removed by moving
// the bodies, at most max_push_out_speed a step, but the bodies keep none of that
// motion as velocity, and the push adds no friction (RigidRow: where a side deforms the
// step's solve pushes out as before).
//
// Before the solve (AllowStartingOverlaps) every starting overlap is allowed to stay:
// the step's solve then gives what the contacts do besides pushing out (its forces
// are the step's forces, its motion the bodies' velocities). After it (PushOutOverlaps)
// a frictionless normal-only solve on the same Delassus operator finds the normal
// impulses that remove what the push-out speed allows of each overlap without
// pushing any other contact in; their motion is added to the positions only. This is
// the split of position and velocity of Box2D's relaxed solve and Bullet's split
// impulse, in the paper's position-level step.
#include <algorithm>
#include <chrono>

#include "core/world.h"

namespace gs {
namespace {

// the part of a starting overlap the push-out speed removes in this step
double PushedOut(double gap_start, const WorldParams& p) {
  const double overlap = std::max(0.0, -gap_start);
  return p.max_push_out_speed > 0.0 ? std::min(overlap, p.max_push_out_speed * p.dt) : overlap;
}

// A contact between two rigid surfaces: its starting overlap is a geometric one (a body
// placed inside another, a sampled ball's control point turned under a plane). Where a
// side deforms, an overlap is mostly where the deformed surfaces' interpolation
// between control points misses (a point entering a pressed skin) and belongs to the
// contact's load: it is pushed out by the step's solve, with its friction, as before
// (pushed frictionless, a soft pinch sliding through such points held 0.06 % of its
// weight too little by friction: validate pinch).
bool RigidRow(const World& w, const ContactRow& r) {
  return !w.bodies[r.contact.body[0]].deform.enabled() && !w.bodies[r.contact.body[1]].deform.enabled();
}

// the solver's accumulators back to zero on the points they can reach (SolveContacts
// starts from there: free motion cleared them)
void ClearSolveAccumulators(World& w) {
  for (Articulation& a : w.articulations) a.dq.setZero();
  for (Body& b : w.bodies)
    for (int j : b.live) b.u_acc[j].setZero();
}

}  // namespace

bool AllowStartingOverlaps(World& w) {
  w.push_out_pending = false;
  // the rows are kept in what Finalize reserved (no allocation in the step); past it
  // (more contacts than max_contacts allows for) the push-out keeps its speed
  if (!w.params.push_out_keeps_no_speed || w.rows.size() + w.limit_rows.size() > w.push_keep.capacity())
    return false;
  for (ContactRow& r : w.rows) {
    if (!(r.gap_start < 0.0) || !RigidRow(w, r)) continue;
    const double overlap = -r.gap_start;
    r.q[0] += overlap - r.held_back;
    r.held_back = overlap;
    w.push_out_pending = true;
  }
  for (LimitRow& l : w.limit_rows) {
    if (!(l.gap_start < 0.0)) continue;
    const double overlap = -l.gap_start;
    l.q += overlap - l.held_back;
    l.held_back = overlap;
    w.push_out_pending = true;
  }
  return w.push_out_pending;
}

void PushOutOverlaps(World& w) {
  if (!w.push_out_pending) return;
  w.push_out_pending = false;
  // a step out of time that kept its warm start keeps the overlaps too (not deepened:
  // they were allowed to stay); a later step pushes them out
  if (w.profile.solve_skipped) return;
  const StepProfile first = w.profile;
  // the step's solve: velocities, forces, and the motion the push is added to
  for (Articulation& a : w.articulations) a.dq_velocity = a.dq;
  for (Body& b : w.bodies)
    for (int j : b.live) b.u_acc_kept[j] = b.u_acc[j];
  w.push_keep.clear();
  for (ContactRow& r : w.rows) {
    w.push_keep.push_back({r.q, r.r, r.mu});
    r.q = Vec3(RigidRow(w, r) ? -PushedOut(r.gap_start, w.params) : 0.0, 0.0, 0.0);
    r.r.setZero();
    r.mu = 0.0;
  }
  for (LimitRow& l : w.limit_rows) {
    w.push_keep.push_back({Vec3(l.q, 0.0, 0.0), Vec3(l.r, 0.0, 0.0), 0.0});
    l.q = -PushedOut(l.gap_start, w.params);
    l.r = 0.0;
  }
  ClearSolveAccumulators(w);
  const double sweep_s = w.last_sweep_s_;  // the budget's estimate of a step's sweep stays the step solve's
  SolveContacts(w, /*may_skip=*/false);    // every row frictionless: normals only
  w.last_sweep_s_ = sweep_s;
  // positions: the step's motion and the push's; the step's forces and problem back
  for (Articulation& a : w.articulations) a.dq += a.dq_velocity;
  for (Body& b : w.bodies)
    for (int j : b.live) b.u_acc[j] += b.u_acc_kept[j];
  size_t k = 0;
  for (ContactRow& r : w.rows) {
    const World::PushKeep& kept = w.push_keep[k++];
    r.q = kept.q;
    r.r = kept.r;
    r.mu = kept.mu;
  }
  for (LimitRow& l : w.limit_rows) {
    const World::PushKeep& kept = w.push_keep[k++];
    l.q = kept.q[0];
    l.r = kept.r[0];
  }
  // the step's solve is the one reported (its sweeps, its residual); the push's time is added
  StepProfile& p = w.profile;
  const double push_time = p.solve;
  const bool push_stopped = p.budget_stopped;
  p = first;  // its work too: the push's normal-only sweeps are counted apart
  p.solve += push_time;
  p.budget_stopped = p.budget_stopped || push_stopped;
  p.push_out_split = true;
  ++p.work.push_out_splits;
}

}  // namespace gs
