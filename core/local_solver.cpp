#include "core/local_solver.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

namespace gs {

Vec3 ProjectOntoCone(const Vec3& x, double mu) {
  const double xn = x[0];
  const double xt = std::sqrt(x[1] * x[1] + x[2] * x[2]);
  if (mu * xt <= -xn) return Vec3::Zero();
  if (xt <= mu * xn) return x;
  const double n = (mu * xt + xn) / (1.0 + mu * mu);
  return Vec3(n, mu * n * x[1] / xt, mu * n * x[2] / xt);
}

double LocalErrorSquared(const Vec3& r, const Vec3& u, double mu) {
  const Vec3 ut(u[0] + mu * std::sqrt(u[1] * u[1] + u[2] * u[2]), u[1], u[2]);
  return (r - ProjectOntoCone(r - ut, mu)).squaredNorm();
}

namespace {

// for slip direction d = (cos a, sin a): the normal force making u_n = 0 with
// r = rn (1, mu d), the tangential velocity and g = u_t x d (zero when parallel)
struct SlideEval {
  double rn, g, along;  // along = u_t . d (must be < 0: slip opposed to friction)
};

inline SlideEval EvalSlide(const Mat3& W, const Vec3& q, double mu, double a) {
  const double c = std::cos(a), s = std::sin(a);
  const Vec3 dir(1.0, mu * c, mu * s);
  const double wn = W.row(0).dot(dir);
  SlideEval e;
  e.rn = wn > 0 ? -q[0] / wn : -1.0;
  const Vec3 u = W * (e.rn * dir) + q;
  e.g = u[1] * s - u[2] * c;
  e.along = u[1] * c + u[2] * s;
  return e;
}

// refines a bracketed root of g on [a0, a1] by bisection with secant steps
double RefineAngle(const Mat3& W, const Vec3& q, double mu, double a0, double g0, double a1, double g1) {
  for (int it = 0; it < 60; ++it) {
    double am = (g1 != g0) ? a0 - g0 * (a1 - a0) / (g1 - g0) : 0.5 * (a0 + a1);
    // keep the secant step well inside the bracket, else bisect
    const double lo = std::min(a0, a1), hi = std::max(a0, a1), w = hi - lo;
    if (!(am > lo + 0.01 * w && am < hi - 0.01 * w)) am = 0.5 * (a0 + a1);
    const double gm = EvalSlide(W, q, mu, am).g;
    if ((gm < 0) == (g0 < 0)) {
      a0 = am;
      g0 = gm;
    } else {
      a1 = am;
      g1 = gm;
    }
    if (std::abs(a1 - a0) < 1e-13) break;
  }
  return 0.5 * (a0 + a1);
}

// Newton's method on g(a) from a0: a few steps when a0 is near the root (the
// previous sweep's angle). Returns false when it does not converge cleanly.
bool NewtonAngle(const Mat3& W, const Vec3& q, double mu, double a, double* root) {
  for (int it = 0; it < 12; ++it) {
    const double c = std::cos(a), s = std::sin(a);
    const Vec3 dir(1.0, mu * c, mu * s), ddir(0.0, -mu * s, mu * c);
    const double wn = W.row(0).dot(dir);
    if (!(wn > 0.0)) return false;
    const double rn = -q[0] / wn;
    if (!(rn > 0.0)) return false;
    const double drn = q[0] * W.row(0).dot(ddir) / (wn * wn);
    const Vec3 wd = W * dir, wdd = W * ddir;
    const Vec3 u = rn * wd + q;
    const Vec3 du = drn * wd + rn * wdd;
    const double g = u[1] * s - u[2] * c;
    const double dg = du[1] * s + u[1] * c - du[2] * c + u[2] * s;
    if (!(dg != 0.0) || !std::isfinite(dg)) return false;
    const double step = std::clamp(g / dg, -0.5, 0.5);
    a -= step;
    if (std::abs(step) < 1e-13) {
      *root = a;
      return true;
    }
  }
  return false;
}

}  // namespace

ELocalCase SolveLocalCoulomb(const Mat3& W, const Vec3& q, double mu, Vec3* r, double* angle_hint) {
  // separation
  if (q[0] >= 0.0) {
    r->setZero();
    return ELocalCase::Separate;
  }
  const double wnn = W(0, 0);
  if (!(wnn > 0.0) || !std::isfinite(wnn)) {
    r->setZero();
    return ELocalCase::Fallback;
  }
  // frictionless: normal only
  if (mu <= 0.0) {
    *r = Vec3(-q[0] / wnn, 0.0, 0.0);
    return ELocalCase::Stick;
  }
  // stick: u = 0 (W is not assumed symmetric: some real problems' blocks are not)
  Mat3 W_inv;
  bool invertible = false;
  double det = 0.0;
  W.computeInverseAndDetWithCheck(W_inv, det, invertible, 1e-300);
  const Vec3 rs = invertible ? Vec3(-(W_inv * q)) : Vec3(-q[0] / wnn, 0.0, 0.0);
  if (rs.allFinite() && rs[0] > 0.0 && std::sqrt(rs[1] * rs[1] + rs[2] * rs[2]) <= mu * rs[0]) {
    *r = rs;
    return ELocalCase::Stick;
  }

  // slide: find the slip angle a with u_t anti-parallel to d(a), rn > 0
  auto best_error = [&](double a, Vec3* out) {
    const SlideEval e = EvalSlide(W, q, mu, a);
    if (!(e.rn > 0.0) || e.along > 0.0) return std::numeric_limits<double>::infinity();
    *out = Vec3(e.rn, e.rn * mu * std::cos(a), e.rn * mu * std::sin(a));
    // forces as gaps (wnn r), so that the test below means the same at every
    // force scale (scaling the masses by k scales W by 1/k and r by k)
    const Vec3 x = *out;
    return LocalErrorSquared(wnn * x, W * x + q, mu);
  };
  const double exact = 1e-24 * q.squaredNorm() + 1e-300;  // an exact root, relative to the free gap
  // first guess: the hint, else friction opposing the stick solution's excess
  double a0 = angle_hint && std::isfinite(*angle_hint) ? *angle_hint : std::atan2(rs[2], rs[1]);
  Vec3 cand = Vec3::Zero();
  double err_best = std::numeric_limits<double>::infinity();
  Vec3 r_best = Vec3::Zero();
  double a_best = a0;
  // Newton from the guess (converges in a few steps from last sweep's angle)
  {
    double root;
    if (NewtonAngle(W, q, mu, a0, &root)) {
      const double err = best_error(root, &cand);
      if (err <= exact) {
        err_best = err;
        r_best = cand;
        a_best = root;
      }
    }
  }
  // else a local bracket around the guess, then a full scan
  for (int pass = 0; pass < 2 && err_best > exact; ++pass) {
    const int n = pass == 0 ? 8 : 256;
    const double span = pass == 0 ? 0.5 : 2.0 * M_PI;
    double prev_a = a0 - 0.5 * span;
    SlideEval prev = EvalSlide(W, q, mu, prev_a);
    for (int k = 1; k <= n; ++k) {
      const double a = a0 - 0.5 * span + span * k / n;
      const SlideEval e = EvalSlide(W, q, mu, a);
      if ((e.g < 0) != (prev.g < 0) && e.rn > 0 && prev.rn > 0 && (e.along < 0 || prev.along < 0)) {
        const double root = RefineAngle(W, q, mu, prev_a, prev.g, a, e.g);
        const double err = best_error(root, &cand);
        if (err < err_best) {
          err_best = err;
          r_best = cand;
          a_best = root;
        }
      }
      prev = e;
      prev_a = a;
    }
  }
  if (std::isfinite(err_best)) {
    *r = r_best;
    if (angle_hint) *angle_hint = std::remainder(a_best, 2.0 * M_PI);
    return ELocalCase::Slide;
  }
  // no root found (a strongly coupled or degenerate W): De Saxce fixed point
  // r <- P_K(r - rho (u_n + mu |u_t|, u_t)) with rho below 2 / lambda_max(W)
  const double rho = 1.0 / std::max(W.trace(), 1e-300);
  Vec3 x = ProjectOntoCone(rs.allFinite() ? rs : Vec3(-q[0] / wnn, 0, 0), mu);
  for (int it = 0; it < 2000; ++it) {
    const Vec3 u = W * x + q;
    const Vec3 ut(u[0] + mu * std::sqrt(u[1] * u[1] + u[2] * u[2]), u[1], u[2]);
    const Vec3 nx = ProjectOntoCone(x - rho * ut, mu);
    const double step = (nx - x).squaredNorm();
    x = nx;
    if (step < 1e-30 * (1.0 + x.squaredNorm())) break;
  }
  *r = x.allFinite() ? x : Vec3::Zero();
  return ELocalCase::Fallback;
}

}  // namespace gs
