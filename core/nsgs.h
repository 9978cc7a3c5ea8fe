// Nonsmooth block Gauss-Seidel (NSGS) over the contacts, each 3x3 local
// Coulomb problem solved exactly (local_solver.h), on any Delassus operator
// seen contact by contact:
//   int  NumContacts() const;
//   Mat3 DiagonalBlock(int c) const;            W_cc
//   Vec3 Velocity(int c, const Vec3* r) const;  u_c = q_c + sum_j W_cj r_j (own term included)
//   void ApplyDelta(int c, const Vec3& dr);     r_c changed by dr
//   double Mu(int c) const;
//   double FreeNormSquared() const;             |q|^2 over all contacts
//
// Stopping test. The reported error is Siconos' fc3d measure (local_solver.h) of
// the returned forces, computed exactly in a separate pass. A sweep already
// reads every contact's velocity before its local solve, so it accumulates the
// same measure at no cost on the mixed (partly updated) iterate; the exact pass
// runs only when that estimate says the tolerance may be met, and on the last
// sweep. The in-sweep estimate tracks the exact error within a small factor.
//
// Options: over-relaxation (r <- P_K(r + omega (r_local - r))), and the sweep
// order: forward, or alternating forward/backward (symmetric Gauss-Seidel),
// which damps the order-dependent cycles plain forward sweeps fall into on
// strongly coupled problems.
// Nothing is allocated when the scratch has room for the contacts.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/local_solver.h"

namespace gs {

enum class ESweepOrder { Forward, Alternating };

struct NsgsParams {
  double tolerance = 1e-6;          ///< on the Siconos error
  int max_iterations = 100;         ///< sweeps
  double over_relaxation = 1.0;     ///< omega: r <- r + omega (r_local - r), then projected on the cone
  ESweepOrder order = ESweepOrder::Forward;
};

struct NsgsResult {
  int iterations = 0;
  double error = 0.0;  ///< Siconos fc3d error of the returned forces
  bool converged = false;
  int exact_checks = 0;  ///< exact error passes
};

struct NsgsScratch {
  std::vector<double> angle;  ///< per-contact slip angle hints
  void Reserve(int n) { angle.reserve(n); }
};

/// The Siconos error of forces r (u recomputed through the operator).
template <class Op>
double SiconosError(const Op& op, const Vec3* r) {
  const int n = op.NumContacts();
  double num = 0.0, nr = 0.0, nu = 0.0;
  for (int c = 0; c < n; ++c) {
    const Vec3 u = op.Velocity(c, r);
    num += LocalErrorSquared(r[c], u, op.Mu(c));
    nr += r[c].squaredNorm();
    nu += u.squaredNorm();
  }
  const double nq = op.FreeNormSquared();
  const double den = std::sqrt(std::max({nq, nr, nu}));
  return den > 2.220446049250313e-16 ? std::sqrt(num) / den : std::sqrt(num);
}

/// One local update of contact c; returns its local error before the update
/// (squared) and adds |u|^2, |r|^2 to the sums.
template <class Op>
inline double NsgsUpdate(Op& op, Vec3* r, int c, double omega, double* angle, double* nu, double* nr) {
  const Mat3 W = op.DiagonalBlock(c);
  const Vec3 u = op.Velocity(c, r);
  const double mu = op.Mu(c);
  const double e2 = LocalErrorSquared(r[c], u, mu);
  *nu += u.squaredNorm();
  const Vec3 q_local = u - W * r[c];
  Vec3 x;
  SolveLocalCoulomb(W, q_local, mu, &x, angle);
  if (omega != 1.0) x = ProjectOntoCone(r[c] + omega * (x - r[c]), mu);
  const Vec3 dr = x - r[c];
  if (dr.allFinite()) {
    op.ApplyDelta(c, dr);
    r[c] = x;
  }
  *nr += r[c].squaredNorm();
  return e2;
}

/// One sweep over the contacts (forward, or backward when `backward`); returns
/// the in-sweep estimate of the Siconos error (on the mixed iterate).
template <class Op>
double NsgsSweep(Op& op, Vec3* r, double omega, bool backward, double nq, double* angle) {
  const int n = op.NumContacts();
  double num = 0.0, nu = 0.0, nr = 0.0;
  if (!backward) {
    for (int c = 0; c < n; ++c) num += NsgsUpdate(op, r, c, omega, &angle[c], &nu, &nr);
  } else {
    for (int c = n - 1; c >= 0; --c) num += NsgsUpdate(op, r, c, omega, &angle[c], &nu, &nr);
  }
  const double den = std::sqrt(std::max({nq, nr, nu}));
  return den > 2.220446049250313e-16 ? std::sqrt(num) / den : std::sqrt(num);
}

template <class Op>
NsgsResult SolveNsgs(Op& op, Vec3* r, const NsgsParams& p, NsgsScratch& s) {
  NsgsResult res;
  const int n = op.NumContacts();
  if (n == 0) {
    res.converged = true;
    return res;
  }
  if (static_cast<int>(s.angle.size()) < n) s.angle.resize(n, NAN);
  std::fill(s.angle.begin(), s.angle.begin() + n, NAN);
  const double omega = p.over_relaxation;
  const double nq = op.FreeNormSquared();
  for (int it = 0; it < p.max_iterations; ++it) {
    const bool backward = p.order == ESweepOrder::Alternating && (it & 1);
    const double estimate = NsgsSweep(op, r, omega, backward, nq, s.angle.data());
    res.iterations = it + 1;
    if (estimate <= p.tolerance || it + 1 == p.max_iterations) {
      res.error = SiconosError(op, r);
      ++res.exact_checks;
      if (res.error <= p.tolerance) {
        res.converged = true;
        break;
      }
    }
  }
  return res;
}

}  // namespace gs
