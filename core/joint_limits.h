// Joint limits as unilateral rows of the contact solve (docs/solver.md, "Joint
// limits"). A finger joint j near a limit l gets one LimitRow: with the row's
// sign s (+1 at the lower limit, -1 at the upper) and lever L (m), its gap is
//   g = s L (q_prev + dq_free + dq - l) = q + s L dq_j        (metres of arc)
// and Signorini holds between g and the row's force r >= 0 (N), which acts on
// the joint as the generalized torque s L r. The torque moves the finger's
// accumulator like a contact's J^T f does (dq += A^-1 e_j s L dr), so a contact
// on the fingertip and the limit see each other through A^-1: W_cj = H_c A^-1 e_j s L.
// L makes the row read like a contact (gap in m, W in m/N), so the scaled stopping
// measure, the Newton scaling and the Siconos measure mix no units.
#pragma once

#include "core/world.h"

namespace gs {

/// The row's gap for the accumulated forces: q + s L dq_j (m).
inline double LimitVelocity(const World& w, const LimitRow& l) {
  return l.q + l.sign * l.lever * w.articulations[l.articulation].dq[l.joint];
}

/// The row's gap response alone, s L dq_j (m): W r without q.
inline double LimitResponse(const World& w, const LimitRow& l) {
  return l.sign * l.lever * w.articulations[l.articulation].dq[l.joint];
}

/// dq += A^-1 e_j s L dr: a force change dr (N) of the row moves the finger.
inline void PushLimit(World& w, const LimitRow& l, double dr) {
  Articulation& a = w.articulations[l.articulation];
  a.dq += a.a_inv.col(l.joint) * (l.sign * l.lever * dr);
}

/// The row's 3x3 block for the solvers: W_jj on the normal, zero tangents.
inline Mat3 LimitBlock(const LimitRow& l) {
  Mat3 m = Mat3::Zero();
  m(0, 0) = l.w;
  return m;
}

}  // namespace gs
