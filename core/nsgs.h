// Nonsmooth block Gauss-Seidel (NSGS) over the contacts, each 3x3 local
// Coulomb problem solved exactly (local_solver.h), on any Delassus operator
// seen contact by contact:
//   int  NumContacts() const;
//   Mat3 DiagonalBlock(int c) const;            W_cc
//   Vec3 Velocity(int c, const Vec3* r) const;  u_c = q_c + sum_j W_cj r_j (own term included)
//   void ApplyDelta(int c, const Vec3& dr);     r_c changed by dr
//   double Mu(int c) const;
//   double FreeNormSquared() const;             |q|^2 over all contacts
// The reported error is Siconos' fc3d measure (local_solver.h), computed exactly
// with a separate pass whenever the sweep's own estimate says it may be met.
// Nothing is allocated when the scratch has room for the contacts.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/local_solver.h"

namespace gs {

struct NsgsParams {
  double tolerance = 1e-6;     ///< on the Siconos error
  int max_iterations = 100;    ///< sweeps
  double over_relaxation = 1.0;  ///< omega: r <- r + omega (r_local - r), then projected on the cone
};

struct NsgsResult {
  int iterations = 0;
  double error = 0.0;  ///< Siconos fc3d error of the returned forces
  bool converged = false;
};

struct NsgsScratch {
  std::vector<double> angle;  ///< per-contact slip angle hints
  std::vector<Vec3> u;
  void Reserve(int n) {
    angle.reserve(n);
    u.reserve(n);
  }
};

/// The Siconos error of forces r (u recomputed through the operator).
template <class Op>
double SiconosError(const Op& op, const Vec3* r, NsgsScratch& s) {
  const int n = op.NumContacts();
  double num = 0.0, nr = 0.0, nu = 0.0;
  for (int c = 0; c < n; ++c) {
    const Vec3 u = op.Velocity(c, r);
    num += LocalErrorSquared(r[c], u, op.Mu(c));
    nr += r[c].squaredNorm();
    nu += u.squaredNorm();
  }
  const double nq = op.FreeNormSquared();
  (void)s;
  const double den = std::sqrt(std::max({nq, nr, nu}));
  return den > 2.220446049250313e-16 ? std::sqrt(num) / den : std::sqrt(num);
}

template <class Op>
NsgsResult SolveNsgs(Op& op, Vec3* r, const NsgsParams& p, NsgsScratch& s) {
  NsgsResult res;
  const int n = op.NumContacts();
  if (static_cast<int>(s.angle.size()) < n) s.angle.resize(n, NAN);
  std::fill(s.angle.begin(), s.angle.begin() + n, NAN);
  const double omega = p.over_relaxation;
  for (int it = 0; it < p.max_iterations; ++it) {
    double change = 0.0, size = 0.0;
    for (int c = 0; c < n; ++c) {
      const Mat3 W = op.DiagonalBlock(c);
      const Vec3 u = op.Velocity(c, r);
      const Vec3 q_local = u - W * r[c];
      Vec3 x;
      SolveLocalCoulomb(W, q_local, op.Mu(c), &x, &s.angle[c]);
      if (omega != 1.0) x = ProjectOntoCone(r[c] + omega * (x - r[c]), op.Mu(c));
      const Vec3 dr = x - r[c];
      if (!dr.allFinite()) continue;
      change += dr.squaredNorm();
      size += x.squaredNorm();
      op.ApplyDelta(c, dr);
      r[c] = x;
    }
    res.iterations = it + 1;
    // the exact measure once the sweep barely moved the forces
    if (change <= p.tolerance * p.tolerance * std::max(size, 1e-300) || it + 1 == p.max_iterations) {
      res.error = SiconosError(op, r, s);
      if (res.error <= p.tolerance) {
        res.converged = true;
        break;
      }
    }
  }
  return res;
}

}  // namespace gs
