#include "core/mls.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "core/sym_eigen3.h"

namespace gs {
namespace {

// the points carrying weight around one query: offsets from the query, weights
struct Weighted {
  Vec3 d;
  double w;
};
constexpr int kMaxWeighted = 512;

// one pass over the candidates: weights, a(p) - p, the normal, and the kept points
struct LocalFit {
  Vec3 mean_offset = Vec3::Zero();  // a(p) - p
  Vec3 normal = Vec3::Zero();
  double weight_sum = 0.0;
  int count = 0;
};

bool FitAt(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& p,
           const MlsParams& params, Weighted* kept, LocalFit* out) {
  const double inv_h2 = 1.0 / (params.bandwidth * params.bandwidth);
  const double cut = params.support * params.bandwidth;
  const double cut2 = cut * cut;
  double ws = 0.0;
  Vec3 s1 = Vec3::Zero(), nsum = Vec3::Zero();
  Mat3 s2 = Mat3::Zero();
  int k = 0;
  for (int i = 0; i < count; ++i) {
    const Vec3 d = positions[idx[i]] - p;
    const double d2 = d.squaredNorm();
    if (d2 > cut2) continue;
    // truncated gaussian theta(x) = exp(-x^2/h^2) (section 3.2)
    const double w = std::exp(-d2 * inv_h2);
    ws += w;
    s1 += w * d;
    s2.noalias() += w * d * d.transpose();
    nsum += w * normals[idx[i]];
    if (kept && k < kMaxWeighted) kept[k] = {d, w};
    ++k;
  }
  if (k < 3 || !(ws > 1e-300)) return false;
  // eq. 2: the weighted mean; eq. 3: the weighted covariance, smallest eigenvector
  const Vec3 a = s1 / ws;
  const Mat3 B = s2 / ws - a * a.transpose();
  Vec3 n = SmallestEigenvector(B);
  if (n.dot(nsum) < 0.0) n = -n;
  out->mean_offset = a;
  out->normal = n;
  out->weight_sum = ws;
  out->count = std::min(k, kMaxWeighted);
  return n.allFinite() && a.allFinite();
}

// weighted least-squares quadratic height field over the plane (origin a, normal n,
// tangents t1, t2) of the kept points, in units of h; false when ill-conditioned
bool QuadricCoefficients(const Weighted* kept, int k, const Vec3& a, const Vec3& n, const Vec3& t1, const Vec3& t2,
                         double h, Eigen::Matrix<double, 6, 1>* coeffs) {
  if (k < 8) return false;
  // coordinates in units of the bandwidth keep the moments well scaled
  const double s = 1.0 / h;
  // moments of the monomials (1, u, v, uu, uv, vv): sums of w u^i v^j up to degree 4
  double S[5][5] = {};
  double H[3][3] = {};
  for (int j = 0; j < k; ++j) {
    const Vec3 d = (kept[j].d - a) * s;
    const double u = d.dot(t1), v = d.dot(t2), ht = d.dot(n), w = kept[j].w;
    const double uu = u * u, vv = v * v, wu = w * u, wv = w * v;
    S[0][0] += w;
    S[1][0] += wu;
    S[0][1] += wv;
    S[2][0] += wu * u;
    S[1][1] += wu * v;
    S[0][2] += wv * v;
    S[3][0] += wu * uu;
    S[2][1] += wu * u * v;
    S[1][2] += wu * vv;
    S[0][3] += wv * vv;
    S[4][0] += wu * u * uu;
    S[3][1] += wu * uu * v;
    S[2][2] += w * uu * vv;
    S[1][3] += wu * v * vv;
    S[0][4] += wv * v * vv;
    const double wh = w * ht;
    H[0][0] += wh;
    H[1][0] += wh * u;
    H[0][1] += wh * v;
    H[2][0] += wh * uu;
    H[1][1] += wh * u * v;
    H[0][2] += wh * vv;
  }
  static const int kExp[6][2] = {{0, 0}, {1, 0}, {0, 1}, {2, 0}, {1, 1}, {0, 2}};
  Eigen::Matrix<double, 6, 6> A;
  Eigen::Matrix<double, 6, 1> b;
  for (int r = 0; r < 6; ++r) {
    b[r] = H[kExp[r][0]][kExp[r][1]];
    for (int c = 0; c < 6; ++c) A(r, c) = S[kExp[r][0] + kExp[c][0]][kExp[r][1] + kExp[c][1]];
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(A);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  // a tiny pivot relative to the largest means the neighbours do not span a quadric
  const auto D = ldlt.vectorD();
  if (!(D.minCoeff() > 1e-12 * D.maxCoeff())) return false;
  *coeffs = ldlt.solve(b);
  return coeffs->allFinite();
}

// The point of the height field g(u, v) = c . (1, u, v, uu, uv, vv) closest to
// (U, V, Z), all in units of h, by Newton from (U, V). False when there is no
// unique closest point near it (the query beyond the centre of curvature, or
// Newton not settling): the caller then takes the point straight below.
bool ClosestOnQuadric(const Eigen::Matrix<double, 6, 1>& c, double U, double V, double Z, double* u_out,
                      double* v_out) {
  double u = U, v = V;
  for (int it = 0; it < 8; ++it) {
    const double g = c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v;
    const double gu = c[1] + 2.0 * c[3] * u + c[4] * v;
    const double gv = c[2] + c[4] * u + 2.0 * c[5] * v;
    const double r = g - Z;
    // gradient and Hessian of half the squared distance
    const double fu = (u - U) + r * gu, fv = (v - V) + r * gv;
    const double a11 = 1.0 + gu * gu + 2.0 * r * c[3];
    const double a12 = gu * gv + r * c[4];
    const double a22 = 1.0 + gv * gv + 2.0 * r * c[5];
    const double det = a11 * a22 - a12 * a12;
    if (!(a11 > 0.0 && det > 1e-12)) return false;
    const double du = -(a22 * fu - a12 * fv) / det;
    const double dv = -(a11 * fv - a12 * fu) / det;
    u += du;
    v += dv;
    if (!(std::abs(u - U) < 4.0 && std::abs(v - V) < 4.0)) return false;  // left the fit's support
    if (du * du + dv * dv < 1e-24) {
      *u_out = u;
      *v_out = v;
      return true;
    }
  }
  return false;
}

}  // namespace

MlsParams RecommendedMlsParams(double spacing) {
  MlsParams p;
  p.bandwidth = 1.5 * spacing;
  p.support = 2.5;
  p.max_iterations = 4;
  p.tolerance = 1e-3;
  p.quadric = true;
  return p;
}

bool MlsPlaneFit(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& p,
                 const MlsParams& params, MlsFit* out) {
  LocalFit f;
  if (!FitAt(positions, normals, idx, count, p, params, nullptr, &f)) return false;
  out->mean = p + f.mean_offset;
  out->normal = f.normal;
  out->weight_sum = f.weight_sum;
  out->neighbours = f.count;
  return true;
}

double MlsImplicit(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& p,
                   const MlsParams& params) {
  MlsFit f;
  if (!MlsPlaneFit(positions, normals, idx, count, p, params, &f)) return std::nan("");
  // eq. 1: f(p) = n(p) . (a(p) - p)
  return f.normal.dot(f.mean - p);
}

Vec3 MlsPatch::Closest(const Vec3& x) const {
  const Vec3 d = (x - origin) / h;
  const double U = d.dot(t1), V = d.dot(t2), Z = d.dot(normal);
  double u = U, v = V;
  const Eigen::Matrix<double, 6, 1> cc = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(c);
  if (!ClosestOnQuadric(cc, U, V, Z, &u, &v)) {
    u = U;
    v = V;
  }
  const double g = c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v;
  return origin + (u * t1 + v * t2 + g * normal) * h;
}

bool MlsFitPatch(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& p,
                 const MlsParams& params, MlsPatch* out) {
  Weighted kept[kMaxWeighted];
  LocalFit f;
  if (!FitAt(positions, normals, idx, count, p, params, kept, &f)) return false;
  out->origin = p + f.mean_offset;
  out->normal = f.normal;
  out->t1 = AnyPerpendicular(f.normal);
  out->t2 = f.normal.cross(out->t1);
  out->h = params.bandwidth;
  Eigen::Matrix<double, 6, 1> c = Eigen::Matrix<double, 6, 1>::Zero();
  if (params.quadric && !QuadricCoefficients(kept, f.count, f.mean_offset, f.normal, out->t1, out->t2,
                                             params.bandwidth, &c))
    c.setZero();
  for (int i = 0; i < 6; ++i) out->c[i] = c[i];
  return true;
}

bool MlsProject(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& p,
                const MlsParams& params, MlsProjection* out) {
  return MlsProjectFrom(positions, normals, idx, count, p, p, params, out);
}

bool MlsProjectStep(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                    const Vec3& q, const MlsParams& params, Vec3* next, Vec3* normal) {
  Weighted kept[kMaxWeighted];
  const double h = params.bandwidth;
  LocalFit f;
  if (!FitAt(positions, normals, idx, count, q, params, kept, &f)) return false;
  // the reference plane (a, n) at q, then the quadric over it; the new point is
  // the one of the quadric closest to x (of the plane when there is no quadric)
  const Vec3 origin = q + f.mean_offset;
  const Vec3& n = f.normal;
  *next = x - (x - origin).dot(n) * n;
  *normal = n;
  Eigen::Matrix<double, 6, 1> c;
  const Vec3 t1 = AnyPerpendicular(n), t2 = n.cross(t1);
  if (params.quadric && QuadricCoefficients(kept, f.count, f.mean_offset, n, t1, t2, h, &c)) {
    const Vec3 d = (x - origin) / h;
    const double U = d.dot(t1), V = d.dot(t2), Z = d.dot(n);
    double u = U, v = V;
    if (!ClosestOnQuadric(c, U, V, Z, &u, &v)) {
      u = U;
      v = V;
    }
    const double g = c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v;
    const double gu = c[1] + 2.0 * c[3] * u + c[4] * v;
    const double gv = c[2] + c[4] * u + 2.0 * c[5] * v;
    const Vec3 qn = (n - gu * t1 - gv * t2).normalized();
    const Vec3 qp = origin + (u * t1 + v * t2 + g * n) * h;
    if (qp.allFinite() && qn.allFinite()) {
      *next = qp;
      *normal = qn;
    }
  }
  return next->allFinite() && normal->allFinite();
}

bool MlsProjectFrom(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                    const Vec3& start, const MlsParams& params, MlsProjection* out) {
  Vec3 q = start;
  Vec3 normal = Vec3::UnitZ();
  out->converged = false;
  out->iterations = 0;
  for (int it = 0; it < params.max_iterations; ++it) {
    Vec3 next;
    if (!MlsProjectStep(positions, normals, idx, count, x, q, params, &next, &normal)) return false;
    const double moved = (next - q).norm();
    q = next;
    out->iterations = it + 1;
    if (moved < params.tolerance * params.bandwidth) {
      out->converged = true;
      break;
    }
  }
  out->point = q;
  out->normal = normal;
  return q.allFinite() && normal.allFinite();
}

}  // namespace gs
