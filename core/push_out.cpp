// Push-out without speed for a placement's overlap: a body placed inside another (a
// box set on a table at its half height stands 0.125 mm inside its own MLS surface,
// whose quadric fits round its edges a little outward) is pushed out at most
// max_push_out_speed a step; with that speed kept as velocity it was thrown (the box
// jumped 0.54 mm, and on a slope where it should stay it slid 2.75 mm in the air).
// For the steps a free body takes to work off the overlap it starts the scene with
// (CountPlacementSteps), its rows are split into position and velocity, as Box2D's
// relaxed solve and Bullet's split impulse do:
// - before the solve (AllowStartingOverlaps) each of their starting overlaps is
//   allowed to stay: the step's solve keeps it from deepening and gives everything
//   else the contacts do (its forces are the step's, its motion the velocities);
// - after it (PushOutOverlaps) a frictionless normal-only solve on the same Delassus
//   operator removes what the push-out speed allows of those overlaps without pushing
//   any other contact in; its motion is added to the positions only.
#include <algorithm>
#include <cmath>

#include "core/world.h"

namespace gs {
namespace {

// the part of a starting overlap the push-out speed removes in this step
double PushedOut(double gap_start, const WorldParams& p) {
  const double overlap = std::max(0.0, -gap_start);
  return p.max_push_out_speed > 0.0 ? std::min(overlap, p.max_push_out_speed * p.dt) : overlap;
}

// A row of a body still working off the overlap it was placed with. Only a placement's
// overlap is pushed out without speed: in a contact that slides under load (a pinch
// squeezed while it slips) two-pass control points slide over the other sampled surface
// and start every step overlapping a little, and that overlap carries part of the
// squeeze: pushed frictionless it held 0.08 % of the weight too little by friction
// (validate pinch: the two-pass pinches slid 1.7-4.1 % fast at 0.98 mu*). The step's
// solve pushes those out with their friction, as before.
bool PlacementRow(const World& w, const ContactRow& r) {
  return w.bodies[r.contact.body[0]].placement_steps > 0 || w.bodies[r.contact.body[1]].placement_steps > 0;
}

// An overlap this small (m) is rounding: a body whose rows start no deeper than it has
// worked its placement off
constexpr double kPlacementWorkedOff = 1e-9;

// At the first step, every free body that starts overlapping is given twice the steps
// its deepest overlap takes at the push-out speed, and ten more, as a bound: the push
// removes up to the speed's share a step, to the solver's tolerance. Later steps count
// down, and end a body's placement at the first step none of its rows starts
// overlapping (what is left after the bound is pushed out as any overlap is)
void CountPlacementSteps(World& w) {
  if (w.step_count > 0) {
    for (Body& b : w.bodies) b.placement_overlap = false;
    for (const ContactRow& r : w.rows)
      if (r.gap_start < -kPlacementWorkedOff)
        for (int side : r.contact.body) w.bodies[side].placement_overlap = true;
    for (Body& b : w.bodies)
      if (b.placement_steps > 0) b.placement_steps = b.placement_overlap ? b.placement_steps - 1 : 0;
    return;
  }
  const double per_step = w.params.max_push_out_speed * w.params.dt;
  for (const ContactRow& r : w.rows) {
    if (!(r.gap_start < -kPlacementWorkedOff)) continue;
    const int steps = per_step > 0.0 ? 2 * static_cast<int>(std::ceil(-r.gap_start / per_step)) + 10 : 10;
    for (int side : r.contact.body) {
      Body& b = w.bodies[side];
      if (b.motion == EMotion::Free) b.placement_steps = std::max(b.placement_steps, steps);
    }
  }
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
  CountPlacementSteps(w);
  for (ContactRow& r : w.rows) {
    if (!(r.gap_start < 0.0) || !PlacementRow(w, r)) continue;
    const double overlap = -r.gap_start;
    r.q[0] += overlap - r.held_back;
    r.held_back = overlap;
    w.push_out_pending = true;
  }
  // (a joint limit's violation moves a quasi-static finger, which keeps no speed)
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
    r.q = Vec3(PlacementRow(w, r) ? -PushedOut(r.gap_start, w.params) : 0.0, 0.0, 0.0);
    r.r.setZero();
    r.mu = 0.0;
  }
  for (LimitRow& l : w.limit_rows) {
    w.push_keep.push_back({Vec3(l.q, 0.0, 0.0), Vec3(l.r, 0.0, 0.0), 0.0});
    l.q = 0.0;  // pushed out by the step's solve; only kept from going in
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
