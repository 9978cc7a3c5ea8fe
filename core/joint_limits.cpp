// Joint-limit rows (part of the contact space, see core/joint_limits.h): every
// finger joint within WorldParams::joint_limit_margin of a limit, at the step's
// start or after its free motion, gets a frictionless unilateral row solved with
// the contacts. Its gap follows the contacts' convention: position level after
// the free motion (q_prev + dq_free, the configuration collision detection saw),
// and a violation present at the step's start is removed at most
// max_push_out_speed fast (at the row's lever), like a starting overlap.
#include <algorithm>
#include <cmath>

#include "core/joint_limits.h"

namespace gs {
namespace {

constexpr int kLimitSlotsPerFinger = 8;  // 4 joints x 2 ends

// The finger's length beyond joint j (m): a joint turn of 1 rad moves the
// fingertip about this far, so the row's gap and force read like a contact's.
double JointLever(const FingerModel& m, int j) {
  double lever = 0.0;
  for (int k = std::max(0, j - 1); k < 3; ++k) lever += m.link_lengths[k];
  return (lever > 0.0 && std::isfinite(lever)) ? lever : 1.0;
}

// The row of joint j's limit `end` (0 low, 1 high) of finger fi when it is near.
void AddLimitRow(World& w, int fi, int j, int end) {
  const Finger& f = w.hand.fingers[fi];
  const Articulation& a = w.articulations[f.articulation];
  const double limit = f.model.limits[j][end];
  const double sign = end == 0 ? 1.0 : -1.0;
  const double start = sign * (f.q_prev[j] - limit);
  const double free = sign * (f.q_prev[j] + a.dq_free[j] - limit);
  // far from the limit (or not finite: free motion has rejected the step)
  if (!(std::min(start, free) <= w.params.joint_limit_margin)) return;
  LimitRow& l = w.limit_rows.emplace_back();
  l.slot = fi * kLimitSlotsPerFinger + 2 * j + end;
  l.finger = fi;
  l.joint = j;
  l.articulation = f.articulation;
  l.sign = sign;
  l.lever = JointLever(f.model, j);
  l.w = l.lever * l.lever * a.a_inv(j, j);
  l.gap_start = l.lever * start;
  l.q = l.lever * free;
  l.held_back = 0.0;
  if (w.params.max_push_out_speed > 0.0) {
    l.held_back = std::max(0.0, -l.gap_start - w.params.max_push_out_speed * w.params.dt);
    l.q += l.held_back;
  }
  const size_t slot = static_cast<size_t>(l.slot);
  l.r = slot < w.limit_warm.size() ? w.limit_warm[slot] : 0.0;
}

}  // namespace

void BuildJointLimitRows(World& w) {
  w.limit_rows.clear();
  const int fingers = static_cast<int>(w.hand.fingers.size());
  for (int fi = 0; fi < fingers; ++fi) {
    if (w.hand.fingers[fi].articulation < 0) continue;
    for (int j = 0; j < 4; ++j)
      for (int end = 0; end < 2; ++end) AddLimitRow(w, fi, j, end);
  }
  w.profile.work.limit_rows = static_cast<int>(w.limit_rows.size());
}

void KeepLimitForces(World& w) {
  w.limit_warm.assign(kLimitSlotsPerFinger * w.hand.fingers.size(), 0.0);
  for (const LimitRow& l : w.limit_rows) w.limit_warm[l.slot] = l.r;
}

}  // namespace gs
