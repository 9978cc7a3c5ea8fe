// The articulated part of a contact row: H = sum over its sides of
// sign * frame * J_side, applied without forming it for free bodies.
//
// A free body's J at a material point with lever arm l from the centre is
// [I, -[l]x]: J dq = v + w x l and J^T f = (f, l x f). Its mobility A^-1 is
// block diagonal (free_motion.cpp: a linear and an angular 3x3 block), so
// A^-1 J^T f = (A_lin^-1 f, A_ang^-1 (l x f)) and J A^-1 J^T = A_lin^-1 -
// [l]x A_ang^-1 [l]x. A side keeps l (24 bytes); a finger's side keeps its
// h and g = A^-1 h^T in World::side_jacobians.
#pragma once

#include "core/world.h"

namespace gs {

/// J q of a free side: the velocity (or displacement) of its material point for a
/// body motion q = (linear, angular), world coordinates.
inline Vec3 FreeSideMotion(const Vec6& q, const Vec3& lever) { return q.head<3>() + q.tail<3>().cross(lever); }

/// H dq: the articulations' share of the contact's relative velocity (frame coordinates).
inline Vec3 ArticulatedVelocity(const World& w, const ContactRow& row) {
  Vec3 u = Vec3::Zero();  // finger sides, frame coordinates
  Vec3 v = Vec3::Zero();  // free sides, world coordinates
  bool free = false;
  for (const ContactSide& s : row.side) {
    if (s.articulation < 0) continue;
    const Vec6& dq = w.articulations[s.articulation].dq;
    if (s.jacobian >= 0) {
      u += w.side_jacobians[s.jacobian].h * dq;
    } else {
      v += s.sign * FreeSideMotion(dq, s.lever);
      free = true;
    }
  }
  if (free) u += row.frame * v;
  return u;
}

/// The normal row of ArticulatedVelocity.
inline double ArticulatedNormalVelocity(const World& w, const ContactRow& row) {
  double u = 0.0;
  Vec3 v = Vec3::Zero();
  bool free = false;
  for (const ContactSide& s : row.side) {
    if (s.articulation < 0) continue;
    const Vec6& dq = w.articulations[s.articulation].dq;
    if (s.jacobian >= 0) {
      u += w.side_jacobians[s.jacobian].h.row(0).dot(dq);
    } else {
      v += s.sign * FreeSideMotion(dq, s.lever);
      free = true;
    }
  }
  if (free) u += row.frame.row(0).dot(v);
  return u;
}

namespace detail {
// a free side's accumulator moved by the world force f on side 0 (side 1 takes -f)
inline void PushFreeSide(Articulation& a, const ContactSide& s, const Vec3& f) {
  const Vec3 fs = s.sign * f;
  a.dq.head<3>() += a.a_inv.topLeftCorner<3, 3>() * fs;
  a.dq.tail<3>() += a.a_inv.bottomRightCorner<3, 3>() * s.lever.cross(fs);
}
}  // namespace detail

/// dq += A^-1 H^T dr for each articulated side: the force change dr (frame coordinates).
inline void ApplyArticulatedDelta(World& w, const ContactRow& row, const Vec3& dr) {
  Vec3 f;
  bool have_f = false;
  for (const ContactSide& s : row.side) {
    if (s.articulation < 0) continue;
    Articulation& a = w.articulations[s.articulation];
    if (s.jacobian >= 0) {
      a.dq += w.side_jacobians[s.jacobian].g * dr;
      continue;
    }
    if (!have_f) {
      f = row.frame.transpose() * dr;
      have_f = true;
    }
    detail::PushFreeSide(a, s, f);
  }
}

/// ApplyArticulatedDelta of a normal force change alone.
inline void ApplyArticulatedNormalDelta(World& w, const ContactRow& row, double dr) {
  for (const ContactSide& s : row.side) {
    if (s.articulation < 0) continue;
    Articulation& a = w.articulations[s.articulation];
    if (s.jacobian >= 0)
      a.dq += w.side_jacobians[s.jacobian].g.col(0) * dr;
    else
      detail::PushFreeSide(a, s, row.frame.row(0).transpose() * dr);
  }
}

/// J A^-1 J^T of a free side (world coordinates; the sign squares away).
inline Mat3 FreeSideCompliance(const Articulation& a, const Vec3& lever) {
  const Mat3 S = Skew(lever);
  return a.a_inv.topLeftCorner<3, 3>() - S * a.a_inv.bottomRightCorner<3, 3>() * S;
}

}  // namespace gs
