// The exact local Coulomb problem of one contact (paper eq. 5, 10, 11) and the
// error measure of Siconos Numerics' fc3d_compute_error, so that our residuals
// compare with theirs.
//
// Local problem: u = W r + q with W the 3x3 diagonal Delassus block (normal
// first, then two tangents), r in the Coulomb cone K = {|r_t| <= mu r_n}, and
// the De Saxce velocity (u_n + mu |u_t|, u_t) in the dual cone, orthogonal to r.
// Exactly one of three cases holds:
//   separate: q_n >= 0, r = 0;
//   stick:    r = -W^-1 q inside the cone, u = 0;
//   slide:    r on the cone boundary, u_n = 0 and u_t opposed to r_t.
// The slide case is a one-dimensional root find on the slip angle.
#pragma once

#include "core/types.h"

namespace gs {

enum class ELocalCase : uint8_t { Separate, Stick, Slide, Fallback };

/// Solves the local problem exactly. `angle_hint` (radians, in/out) is the slip
/// angle of the last solve of this contact, used as the first guess.
ELocalCase SolveLocalCoulomb(const Mat3& W, const Vec3& q, double mu, Vec3* r, double* angle_hint = nullptr);

/// Projection onto the cone K_mu.
Vec3 ProjectOntoCone(const Vec3& x, double mu);

/// Siconos' per-contact error vector e = r - P_K(r - (u_n + mu |u_t|, u_t)), squared norm.
double LocalErrorSquared(const Vec3& r, const Vec3& u, double mu);

}  // namespace gs
