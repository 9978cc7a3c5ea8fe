#include "core/sym_eigen3.h"

#include <algorithm>
#include <cmath>

namespace gs {
namespace {

// unit eigenvector of the symmetric A for eigenvalue lambda: the largest cross
// product of two rows of A - lambda I; `fallback` when the rows are degenerate
bool EigenvectorFor(const Mat3& A, double lambda, Vec3* out) {
  const Mat3 M = A - lambda * Mat3::Identity();
  const Vec3 c0 = M.row(0).cross(M.row(1));
  const Vec3 c1 = M.row(0).cross(M.row(2));
  const Vec3 c2 = M.row(1).cross(M.row(2));
  const double n0 = c0.squaredNorm(), n1 = c1.squaredNorm(), n2 = c2.squaredNorm();
  const double best = std::max(n0, std::max(n1, n2));
  if (!(best > 1e-24)) return false;
  const Vec3& c = n0 >= n1 && n0 >= n2 ? c0 : (n1 >= n2 ? c1 : c2);
  *out = c / std::sqrt(best);
  return true;
}

// unit eigenvectors of the smallest and largest eigenvalues; for a repeated
// eigenvalue any orthonormal pair of its eigenspace will do
void ExtremeVectors(const Mat3& S, const Vec3& ev, Vec3* v0, Vec3* v2) {
  const bool ok0 = EigenvectorFor(S, ev[0], v0);
  const bool ok2 = EigenvectorFor(S, ev[2], v2);
  if (ok0 && ok2) {
    *v2 -= v2->dot(*v0) * *v0;
    if (v2->squaredNorm() < 1e-24) *v2 = AnyPerpendicular(*v0);
    v2->normalize();
  } else if (ok0) {
    *v2 = AnyPerpendicular(*v0);
  } else if (ok2) {
    *v0 = AnyPerpendicular(*v2);
  } else {
    *v0 = Vec3::UnitX();
    *v2 = Vec3::UnitZ();
  }
}

// eigenvalues of a matrix scaled to entries in [-1, 1], ascending (trigonometric method)
Vec3 ScaledEigenvalues(const Mat3& A) {
  const double p1 = A(0, 1) * A(0, 1) + A(0, 2) * A(0, 2) + A(1, 2) * A(1, 2);
  const double q = A.trace() / 3.0;
  const double d0 = A(0, 0) - q, d1 = A(1, 1) - q, d2 = A(2, 2) - q;
  const double p = std::sqrt((d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * p1) / 6.0);
  if (p < 1e-15) return Vec3::Constant(q);
  const Mat3 B = (A - q * Mat3::Identity()) / p;
  const double r = std::clamp(B.determinant() / 2.0, -1.0, 1.0);
  const double phi = std::acos(r) / 3.0;
  const double hi = q + 2.0 * p * std::cos(phi);
  const double lo = q + 2.0 * p * std::cos(phi + 2.0 * M_PI / 3.0);
  return Vec3(lo, 3.0 * q - hi - lo, hi);
}

}  // namespace

void SymmetricEigen3(const Mat3& A, Vec3* values, Mat3* vectors) {
  const double scale = A.cwiseAbs().maxCoeff();
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    *values = Vec3::Constant(std::isfinite(scale) ? 0.0 : NAN);
    *vectors = Mat3::Identity();
    return;
  }
  const Mat3 S = A / scale;
  const Vec3 ev = ScaledEigenvalues(S);
  *values = ev * scale;
  // the extreme eigenvalues' vectors from cross products, the middle one completes the frame
  Vec3 v0, v2;
  ExtremeVectors(S, ev, &v0, &v2);
  vectors->col(0) = v0;
  vectors->col(1) = v2.cross(v0);
  vectors->col(2) = v2;
  // Rayleigh quotients: exact to rounding even where acos lost digits (repeated eigenvalues)
  for (int i = 0; i < 3; ++i) (*values)[i] = vectors->col(i).dot(A * vectors->col(i));
}

Vec3 SmallestEigenvector(const Mat3& A) {
  const double scale = A.cwiseAbs().maxCoeff();
  if (!(scale > 0.0) || !std::isfinite(scale)) return Vec3::UnitZ();
  const Mat3 S = A / scale;
  const Vec3 ev = ScaledEigenvalues(S);
  Vec3 v0;
  if (EigenvectorFor(S, ev[0], &v0)) return v0;
  Vec3 v0b, v2;
  ExtremeVectors(S, ev, &v0b, &v2);
  return v0b;
}

}  // namespace gs
