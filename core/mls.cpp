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

// weighted least-squares quadratic height field over the plane (origin a, normal n)
// of the kept points; returns false when ill-conditioned. At the query (offset -a
// from the plane's origin) gives the surface point offset and the normal.
bool QuadricAt(const Weighted* kept, int k, const Vec3& a, const Vec3& n, double h, Vec3* point_offset,
               Vec3* normal) {
  if (k < 8) return false;
  const Vec3 t1 = AnyPerpendicular(n), t2 = n.cross(t1);
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
  const Eigen::Matrix<double, 6, 1> c = ldlt.solve(b);
  if (!c.allFinite()) return false;
  const double u = -a.dot(t1) * s, v = -a.dot(t2) * s;
  const double g = c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v;
  const double gu = c[1] + 2.0 * c[3] * u + c[4] * v;
  const double gv = c[2] + c[4] * u + 2.0 * c[5] * v;
  *point_offset = a + (u * t1 + v * t2 + g * n) * h;
  *normal = (n - gu * t1 - gv * t2).normalized();
  return point_offset->allFinite() && normal->allFinite();
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

bool MlsProject(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& p,
                const MlsParams& params, MlsProjection* out) {
  Weighted kept[kMaxWeighted];
  Vec3 q = p;
  Vec3 normal = Vec3::UnitZ();
  out->converged = false;
  out->iterations = 0;
  for (int it = 0; it < params.max_iterations; ++it) {
    LocalFit f;
    if (!FitAt(positions, normals, idx, count, q, params, kept, &f)) return false;
    // onto the reference plane, then onto the quadric over it
    Vec3 step = f.mean_offset.dot(f.normal) * f.normal;
    normal = f.normal;
    if (params.quadric) {
      Vec3 offset, qn;
      if (QuadricAt(kept, f.count, f.mean_offset, f.normal, params.bandwidth, &offset, &qn)) {
        step = offset;
        normal = qn;
      }
    }
    q += step;
    out->iterations = it + 1;
    if (step.norm() < params.tolerance * params.bandwidth) {
      out->converged = true;
      break;
    }
  }
  out->point = q;
  out->normal = normal;
  return q.allFinite() && normal.allFinite();
}

}  // namespace gs
