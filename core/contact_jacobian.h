// The articulated part of a contact row: H = sum over its sides of
// sign * frame * J_side, applied without forming it for free bodies.
//
// A free body's J at a material point with lever arm l from the centre is
// [I, -[l]x]: J dq = v + w x l and J^T f = (f, l x f). Its mobility A^-1 is
// block diagonal (free_motion.cpp: a linear and an angular 3x3 block), so
// A^-1 J^T f = (A_lin^-1 f, A_ang^-1 (l x f)) and J A^-1 J^T = A_lin^-1 -
// [l]x A_ang^-1 [l]x. A side keeps l (24 bytes); a finger's side keeps its
// h and g = A^-1 h^T in World::side_jacobians. The normal row of a side with a
// touch offset a (Contact::touch) ends at l + a: it adds w . (a x n) to the normal
// velocity and f_n (a x n) to the torque (ContactSide::spin).
#pragma once

#include "core/world.h"

namespace gs {

/// J q of a free side: the velocity (or displacement) of its material point for a
/// body motion q = (linear, angular), world coordinates.
inline Vec3 FreeSideMotion(const Vec6& q, const Vec3& lever) { return q.head<3>() + q.tail<3>().cross(lever); }

/// Adds an articulated side's H dq: a finger's to u (frame coordinates), a free
/// body's sign * J dq to v (world coordinates; the caller turns v into the frame once
/// for the whole row).
inline void AddSideVelocity(const World& w, const ContactSide& s, Vec3* u, Vec3* v) {
  const Vec6& dq = w.articulations[s.articulation].dq;
  if (s.jacobian >= 0) {
    *u += w.side_jacobians[s.jacobian].h * dq;
  } else {
    *v += s.sign * FreeSideMotion(dq, s.lever);
    (*u)[0] += s.sign * dq.tail<3>().dot(s.spin);
  }
}

/// The normal row of AddSideVelocity (u: the normal velocity).
inline void AddSideNormalVelocity(const World& w, const ContactSide& s, double* u, Vec3* v) {
  const Vec6& dq = w.articulations[s.articulation].dq;
  if (s.jacobian >= 0) {
    *u += w.side_jacobians[s.jacobian].h.row(0).dot(dq);
  } else {
    *v += s.sign * FreeSideMotion(dq, s.lever);
    *u += s.sign * dq.tail<3>().dot(s.spin);
  }
}

/// dq += A^-1 H^T dr for an articulated side, given the force change dr (frame
/// coordinates) and the same force on side 0 in the world, f = frame^T dr.
inline void PushSide(World& w, const ContactSide& s, const Vec3& dr, const Vec3& f) {
  Articulation& a = w.articulations[s.articulation];
  if (s.jacobian >= 0) {
    a.dq += w.side_jacobians[s.jacobian].g * dr;
    return;
  }
  const Vec3 fs = s.sign * f;
  a.dq.head<3>() += a.a_inv.topLeftCorner<3, 3>() * fs;
  a.dq.tail<3>() += a.a_inv.bottomRightCorner<3, 3>() * (s.lever.cross(fs) + (s.sign * dr[0]) * s.spin);
}

/// PushSide of a normal force change dr alone (f = n dr).
inline void PushSideNormal(World& w, const ContactSide& s, double dr, const Vec3& f) {
  if (s.jacobian >= 0) {
    w.articulations[s.articulation].dq += w.side_jacobians[s.jacobian].g.col(0) * dr;
    return;
  }
  PushSide(w, s, Vec3(dr, 0.0, 0.0), f);
}

/// H dq summed over the row's articulated sides (frame coordinates).
inline Vec3 ArticulatedVelocity(const World& w, const ContactRow& row) {
  Vec3 u = Vec3::Zero(), v = Vec3::Zero();
  for (const ContactSide& s : row.side)
    if (s.articulation >= 0) AddSideVelocity(w, s, &u, &v);
  return u + row.frame * v;
}

/// The normal row of ArticulatedVelocity.
inline double ArticulatedNormalVelocity(const World& w, const ContactRow& row) {
  double u = 0.0;
  Vec3 v = Vec3::Zero();
  for (const ContactSide& s : row.side)
    if (s.articulation >= 0) AddSideNormalVelocity(w, s, &u, &v);
  return u + row.frame.row(0).dot(v);
}

/// dq += A^-1 H^T dr for each articulated side of the row.
inline void ApplyArticulatedDelta(World& w, const ContactRow& row, const Vec3& dr) {
  const Vec3 f = row.frame.transpose() * dr;
  for (const ContactSide& s : row.side)
    if (s.articulation >= 0) PushSide(w, s, dr, f);
}

/// ApplyArticulatedDelta of a normal force change alone.
inline void ApplyArticulatedNormalDelta(World& w, const ContactRow& row, double dr) {
  const Vec3 f = row.frame.row(0).transpose() * dr;
  for (const ContactSide& s : row.side)
    if (s.articulation >= 0) PushSideNormal(w, s, dr, f);
}

/// Adds a free side's H A^-1 H^T to the diagonal block w (frame coordinates; the
/// sign squares away). With f_i the frame's rows (n, t1, t2) and c_i = l x f_i,
/// entry (i, j) is f_i . A_lin^-1 f_j + c_i . A_ang^-1 c_j (the mobility blocks are
/// symmetric), and c_0 = l x n + spin (the normal row's arm ends at the touching
/// point). Inlined, on values the caller holds in registers: a lever or frame just
/// stored to the row and read back at once stalls on store forwarding.
EIGEN_ALWAYS_INLINE void AddFreeSideBlock(const Articulation& a, const Vec3& lever, const Vec3& spin, const Vec3& n,
                                          const Vec3& t1, const Vec3& t2, Mat3* w) {
  const auto al = a.a_inv.topLeftCorner<3, 3>();
  const auto aa = a.a_inv.bottomRightCorner<3, 3>();
  const Vec3 f[3] = {n, t1, t2};
  Vec3 c[3], alf[3], aac[3];
  for (int i = 0; i < 3; ++i) {
    c[i] = lever.cross(f[i]);
    if (i == 0) c[0] += spin;
    alf[i] = al * f[i];
    aac[i] = aa * c[i];
  }
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) {
      const double v = f[i].dot(alf[j]) + c[i].dot(aac[j]);
      (*w)(i, j) += v;
      if (j != i) (*w)(j, i) += v;
    }
}

}  // namespace gs
