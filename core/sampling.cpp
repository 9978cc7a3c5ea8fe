#include "core/sampling.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "core/point_grid.h"

namespace gs {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// candidates generated per output point before elimination
constexpr int kCandidateFactor = 6;

// deterministic uniform doubles: mt19937_64 is fully specified by the standard and
// the conversion below uses only exact operations, so every compiler agrees
class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}
  /// Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  /// Uniform in [-1, 1).
  double Symmetric() { return 2.0 * Uniform() - 1.0; }

 private:
  std::mt19937_64 engine_;
};

// squared length with a fixed evaluation order (Eigen may reorder reductions
// depending on the SIMD target, which would change the last bits)
double Norm2(const Vec3& v) { return (v.x() * v.x() + v.y() * v.y()) + v.z() * v.z(); }
double Dist2(const Vec3& a, const Vec3& b) { return Norm2(a - b); }

// uniform unit vector on the sphere (Marsaglia 1972): only +, *, / and sqrt, so
// the result is bit-identical everywhere (no libm trigonometry)
Vec3 UnitSphere(Rng& rng) {
  for (;;) {
    const double x = rng.Symmetric();
    const double y = rng.Symmetric();
    const double s = x * x + y * y;
    if (s >= 1.0 || s < 1e-12) continue;
    const double f = 2.0 * std::sqrt(1.0 - s);
    const Vec3 v(x * f, y * f, 1.0 - 2.0 * s);
    return v / std::sqrt(Norm2(v));
  }
}

// uniform unit vector in the xy plane, by rejection from the unit disk
Eigen::Vector2d UnitCircle(Rng& rng) {
  for (;;) {
    const double x = rng.Symmetric();
    const double y = rng.Symmetric();
    const double s = x * x + y * y;
    if (s >= 1.0 || s < 1e-6) continue;
    const double n = std::sqrt(s);
    return Eigen::Vector2d(x / n, y / n);
  }
}

// uniform point in the unit disk, by rejection
Eigen::Vector2d UnitDisk(Rng& rng) {
  for (;;) {
    const double x = rng.Symmetric();
    const double y = rng.Symmetric();
    if (x * x + y * y < 1.0) return Eigen::Vector2d(x, y);
  }
}

bool PositiveFinite(double x) { return std::isfinite(x) && x > 0; }

bool ValidShape(const ShapeDesc& s) {
  switch (s.type) {
    case EShape::Box:
      return PositiveFinite(s.half_extents.x()) && PositiveFinite(s.half_extents.y()) &&
             PositiveFinite(s.half_extents.z());
    case EShape::Sphere:
      return PositiveFinite(s.radius);
    case EShape::Ellipsoid:
      return PositiveFinite(s.semi_axes.x()) && PositiveFinite(s.semi_axes.y()) && PositiveFinite(s.semi_axes.z());
    case EShape::Capsule:
      return PositiveFinite(s.radius) && std::isfinite(s.half_length) && s.half_length >= 0;
    case EShape::Cylinder:
      return PositiveFinite(s.radius) && PositiveFinite(s.half_length);
    case EShape::Mesh:
      return false;
  }
  return false;
}

// ---------------------------------------------------------------------------
// Carlson's symmetric elliptic integrals (duplication algorithm)

double CarlsonRF(double x, double y, double z) {
  double mean = (x + y + z) / 3.0;
  for (int it = 0; it < 200; ++it) {
    const double dx = (mean - x) / mean, dy = (mean - y) / mean, dz = (mean - z) / mean;
    if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) < 1e-4) break;
    const double sx = std::sqrt(x), sy = std::sqrt(y), sz = std::sqrt(z);
    const double lambda = sx * (sy + sz) + sy * sz;
    x = 0.25 * (x + lambda);
    y = 0.25 * (y + lambda);
    z = 0.25 * (z + lambda);
    mean = (x + y + z) / 3.0;
  }
  const double dx = (mean - x) / mean, dy = (mean - y) / mean, dz = (mean - z) / mean;
  const double e2 = dx * dy - dz * dz;
  const double e3 = dx * dy * dz;
  return (1.0 + (e2 / 24.0 - 0.1 - 3.0 / 44.0 * e3) * e2 + e3 / 14.0) / std::sqrt(mean);
}

double CarlsonRD(double x, double y, double z) {
  double sum = 0.0, factor = 1.0;
  double mean = 0.2 * (x + y + 3.0 * z);
  for (int it = 0; it < 200; ++it) {
    const double dx = (mean - x) / mean, dy = (mean - y) / mean, dz = (mean - z) / mean;
    if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) < 1e-4) break;
    const double sx = std::sqrt(x), sy = std::sqrt(y), sz = std::sqrt(z);
    const double lambda = sx * (sy + sz) + sy * sz;
    sum += factor / (sz * (z + lambda));
    factor *= 0.25;
    x = 0.25 * (x + lambda);
    y = 0.25 * (y + lambda);
    z = 0.25 * (z + lambda);
    mean = 0.2 * (x + y + 3.0 * z);
  }
  const double dx = (mean - x) / mean, dy = (mean - y) / mean, dz = (mean - z) / mean;
  const double ea = dx * dy, eb = dz * dz;
  const double ec = ea - eb, ed = ea - 6.0 * eb, ee = ed + ec + ec;
  const double series = 1.0 + ed * (-3.0 / 14.0 + 9.0 / 88.0 * ed - 9.0 / 52.0 * dz * ee) +
                        dz * (ee / 6.0 + dz * (-9.0 / 22.0 * ec + dz * 3.0 / 26.0 * ea));
  return 3.0 * sum + factor * series / (mean * std::sqrt(mean));
}

// R_G(x, y, z) for positive arguments, with the middle one as the special
// argument so that the R_D term does not cancel (DLMF 19.21.10)
double CarlsonRG(double x, double y, double z) {
  double v[3] = {x, y, z};
  std::sort(v, v + 3);
  const double a = v[0], c = v[2], m = v[1];
  return 0.5 * (m * CarlsonRF(a, c, m) - (a - m) * (c - m) * CarlsonRD(a, c, m) / 3.0 + std::sqrt(a * c / m));
}

// ---------------------------------------------------------------------------
// closest point on an ellipsoid (Eberly, "Distance from a point to an ellipse,
// an ellipsoid, or a hyperellipsoid": robust bisection on the Lagrange parameter)

// bisection for the Lagrange parameter: find t > 0 with sum_i (n_i / (t + q_i))^2 = 1,
// where q_i = r_i - 1 >= 0, n_i = r_i z_i and the last q is 0 (t = s + 1 in Eberly's
// notation, which keeps full relative precision when the root is close to s = -1)
template <int D>
double BisectRoot(const double* q, const double* n, double g) {
  double t0 = n[D - 1];
  double t1 = 1.0;
  if (g >= 0) {
    double len2 = 0.0, big = 0.0;
    for (int i = 0; i < D; ++i) big = std::max(big, std::abs(n[i]));
    for (int i = 0; i < D; ++i) len2 += (n[i] / big) * (n[i] / big);
    t1 = big * std::sqrt(len2);
  }
  double t = 0.5 * (t0 + t1);
  for (int it = 0; it < 2200; ++it) {
    t = 0.5 * (t0 + t1);
    if (t == t0 || t == t1) break;
    // the closest point divides by t + q_i >= t: that sets the precision needed
    if (t1 - t0 <= 1e-17 * t0) break;
    double f = -1.0;
    for (int i = 0; i < D; ++i) {
      const double ratio = n[i] / (t + q[i]);
      f += ratio * ratio;
    }
    if (f > 0) {
      t0 = t;
    } else if (f < 0) {
      t1 = t;
    } else {
      break;
    }
  }
  return t;
}

// (a / b)^2 - 1 for a >= b > 0, without cancellation
double RatioSquaredMinusOne(double a, double b) { return (a - b) * (a + b) / (b * b); }

// ellipse e0 >= e1 > 0, query y0, y1 >= 0: closest point (x0, x1)
void ClosestOnEllipse(double e0, double e1, double y0, double y1, double* x0, double* x1) {
  if (y1 > 0) {
    if (y0 > 0) {
      const double z[2] = {y0 / e0, y1 / e1};
      const double g = z[0] * z[0] + z[1] * z[1] - 1.0;
      if (g != 0) {
        const double q[2] = {RatioSquaredMinusOne(e0, e1), 0.0};
        const double n[2] = {(q[0] + 1.0) * z[0], z[1]};
        const double t = BisectRoot<2>(q, n, g);
        *x0 = (q[0] + 1.0) * y0 / (t + q[0]);
        *x1 = y1 / t;
      } else {
        *x0 = y0;
        *x1 = y1;
      }
    } else {
      *x0 = 0;
      *x1 = e1;
    }
    return;
  }
  const double numer0 = e0 * y0, denom0 = e0 * e0 - e1 * e1;
  if (numer0 < denom0) {
    const double xde0 = numer0 / denom0;
    *x0 = e0 * xde0;
    *x1 = e1 * std::sqrt(std::max(0.0, 1.0 - xde0 * xde0));
  } else {
    *x0 = e0;
    *x1 = 0;
  }
}

// ellipsoid e0 >= e1 >= e2 > 0, query y >= 0 componentwise: closest point x
void ClosestOnEllipsoid(const double* e, const double* y, double* x) {
  if (y[2] > 0) {
    if (y[1] > 0) {
      if (y[0] > 0) {
        const double z[3] = {y[0] / e[0], y[1] / e[1], y[2] / e[2]};
        const double g = z[0] * z[0] + z[1] * z[1] + z[2] * z[2] - 1.0;
        if (g != 0) {
          const double q[3] = {RatioSquaredMinusOne(e[0], e[2]), RatioSquaredMinusOne(e[1], e[2]), 0.0};
          const double n[3] = {(q[0] + 1.0) * z[0], (q[1] + 1.0) * z[1], z[2]};
          const double t = BisectRoot<3>(q, n, g);
          x[0] = (q[0] + 1.0) * y[0] / (t + q[0]);
          x[1] = (q[1] + 1.0) * y[1] / (t + q[1]);
          x[2] = y[2] / t;
        } else {
          x[0] = y[0];
          x[1] = y[1];
          x[2] = y[2];
        }
      } else {
        x[0] = 0;
        ClosestOnEllipse(e[1], e[2], y[1], y[2], &x[1], &x[2]);
      }
    } else {
      x[1] = 0;
      if (y[0] > 0) {
        ClosestOnEllipse(e[0], e[2], y[0], y[2], &x[0], &x[2]);
      } else {
        x[0] = 0;
        x[2] = e[2];
      }
    }
    return;
  }
  const double denom0 = e[0] * e[0] - e[2] * e[2], denom1 = e[1] * e[1] - e[2] * e[2];
  const double numer0 = e[0] * y[0], numer1 = e[1] * y[1];
  if (numer0 < denom0 && numer1 < denom1) {
    const double xde0 = numer0 / denom0, xde1 = numer1 / denom1;
    const double discr = 1.0 - xde0 * xde0 - xde1 * xde1;
    if (discr > 0) {
      x[0] = e[0] * xde0;
      x[1] = e[1] * xde1;
      x[2] = e[2] * std::sqrt(discr);
      return;
    }
  }
  x[2] = 0;
  ClosestOnEllipse(e[0], e[1], y[0], y[1], &x[0], &x[1]);
}

double EllipsoidDistance(const Vec3& axes, const Vec3& p, Vec3* normal) {
  // sort the axes in decreasing order (stable) and fold p into the first octant
  int perm[3] = {0, 1, 2};
  std::stable_sort(perm, perm + 3, [&](int a, int b) { return axes[a] > axes[b]; });
  double e[3], y[3], x[3];
  for (int k = 0; k < 3; ++k) {
    e[k] = axes[perm[k]];
    y[k] = std::abs(p[perm[k]]);
  }
  ClosestOnEllipsoid(e, y, x);
  Vec3 closest, grad;
  double dist2 = 0;
  for (int k = 0; k < 3; ++k) {
    const int i = perm[k];
    const double sign = p[i] < 0 ? -1.0 : 1.0;
    closest[i] = sign * x[k];
    grad[i] = closest[i] / (e[k] * e[k]);
    dist2 += (x[k] - y[k]) * (x[k] - y[k]);
  }
  const Vec3 q = p.cwiseQuotient(axes);
  const double dist = q.squaredNorm() < 1.0 ? -std::sqrt(dist2) : std::sqrt(dist2);
  if (normal) *normal = grad.normalized();
  return dist;
}

// ---------------------------------------------------------------------------
// weighted sample elimination (Yuksel 2015)

// indexed binary max-heap over candidate weights; ties go to the lower index
class EliminationHeap {
 public:
  explicit EliminationHeap(const std::vector<double>& weights) : w_(weights) {
    const int n = static_cast<int>(weights.size());
    heap_.resize(n);
    pos_.resize(n);
    for (int i = 0; i < n; ++i) heap_[i] = pos_[i] = i;
    for (int k = n / 2 - 1; k >= 0; --k) SiftDown(k);
  }
  bool Empty() const { return heap_.empty(); }
  int Top() const { return heap_[0]; }
  void Pop() {
    const int top = heap_[0];
    const int last = heap_.back();
    heap_.pop_back();
    pos_[top] = -1;
    if (top == last) return;
    heap_[0] = last;
    pos_[last] = 0;
    SiftDown(0);
  }
  /// Call after lowering item i's weight.
  void Decreased(int i) {
    if (pos_[i] >= 0) SiftDown(pos_[i]);
  }

 private:
  bool Higher(int a, int b) const { return w_[a] > w_[b] || (w_[a] == w_[b] && a < b); }
  void SiftDown(int k) {
    const int n = static_cast<int>(heap_.size());
    const int item = heap_[k];
    for (;;) {
      const int l = 2 * k + 1;
      if (l >= n) break;
      int c = l;
      if (l + 1 < n && Higher(heap_[l + 1], heap_[l])) c = l + 1;
      if (!Higher(heap_[c], item)) break;
      heap_[k] = heap_[c];
      pos_[heap_[k]] = k;
      k = c;
    }
    heap_[k] = item;
    pos_[item] = k;
  }
  const std::vector<double>& w_;
  std::vector<int> heap_;
  std::vector<int> pos_;
};

// keeps `count` of the candidates, spread as evenly as the elimination manages;
// returns their indices in increasing order
std::vector<int> Eliminate(const std::vector<Vec3>& cand, double area, int count) {
  const int m = static_cast<int>(cand.size());
  // r_max: the radius of `count` hexagonally packed disks covering `area`
  const double r_max = std::sqrt(area / (2.0 * std::sqrt(3.0) * count));
  const double d_max = 2.0 * r_max;
  // weight limiting: distances below d_min count as d_min (gamma 1.5, beta 0.65)
  const double ratio = static_cast<double>(count) / m;
  const double d_min = d_max * (1.0 - ratio * std::sqrt(ratio)) * 0.65;
  auto weight = [&](double d2) {
    const double d = std::max(std::sqrt(d2), d_min);
    if (d >= d_max) return 0.0;
    const double x = 1.0 - d / d_max;
    const double x2 = x * x, x4 = x2 * x2;
    return x4 * x4;
  };

  // neighbour lists (CSR) within d_max, in the grid's deterministic order
  PointGrid grid;
  grid.Build(cand, d_max);
  std::vector<int> start(static_cast<size_t>(m) + 1, 0);
  std::vector<int> nbr;
  nbr.reserve(static_cast<size_t>(m) * 24);
  std::vector<int> buf;
  std::vector<double> w(m, 0.0);
  for (int i = 0; i < m; ++i) {
    buf.clear();
    grid.Query(cand[i], d_max, &buf);
    double wi = 0.0;
    for (int j : buf) {
      if (j == i) continue;
      nbr.push_back(j);
      wi += weight(Dist2(cand[j], cand[i]));
    }
    w[i] = wi;
    start[i + 1] = static_cast<int>(nbr.size());
  }

  // remove the most crowded candidate until `count` remain
  std::vector<char> removed(m, 0);
  EliminationHeap heap(w);
  for (int left = m; left > count; --left) {
    const int i = heap.Top();
    heap.Pop();
    removed[i] = 1;
    for (int k = start[i]; k < start[i + 1]; ++k) {
      const int j = nbr[k];
      if (removed[j]) continue;
      w[j] -= weight(Dist2(cand[j], cand[i]));
      heap.Decreased(j);
    }
  }
  std::vector<int> kept;
  kept.reserve(count);
  for (int i = 0; i < m; ++i)
    if (!removed[i]) kept.push_back(i);
  return kept;
}

// candidates with normals -> exactly `count` points; the candidates are first put
// in grid-cell order so that neighbours sit close in memory (the output keeps it)
void EliminateInto(const std::vector<Vec3>& pos, const std::vector<Vec3>& nrm, double area, int count,
                   PointCloud* out) {
  const size_t m = pos.size();
  Vec3 lo = pos[0], hi = pos[0];
  for (const Vec3& p : pos) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double cell = std::max(std::sqrt(area / static_cast<double>(count)), 1e-300);
  const Vec3 dims = ((hi - lo) / cell).array().floor() + 1.0;
  std::vector<std::pair<double, uint32_t>> order(m);
  for (size_t i = 0; i < m; ++i) {
    const Vec3 c = ((pos[i] - lo) / cell).array().floor();
    order[i] = {(c.z() * dims.y() + c.y()) * dims.x() + c.x(), static_cast<uint32_t>(i)};
  }
  std::sort(order.begin(), order.end());
  std::vector<Vec3> sorted(m);
  for (size_t i = 0; i < m; ++i) sorted[i] = pos[order[i].second];

  const std::vector<int> kept = Eliminate(sorted, area, count);
  out->positions.resize(kept.size());
  out->normals.resize(kept.size());
  for (size_t k = 0; k < kept.size(); ++k) {
    out->positions[k] = sorted[kept[k]];
    out->normals[k] = nrm[order[kept[k]].second];
  }
}

// one area-uniform candidate on a procedural shape's surface
void ShapeCandidate(const ShapeDesc& s, Rng& rng, Vec3* p, Vec3* n) {
  switch (s.type) {
    case EShape::Box: {
      const Vec3& h = s.half_extents;
      const double face_area[3] = {h.y() * h.z(), h.z() * h.x(), h.x() * h.y()};
      const double total = face_area[0] + face_area[1] + face_area[2];
      const double u = rng.Uniform() * total;
      const int axis = u < face_area[0] ? 0 : (u < face_area[0] + face_area[1] ? 1 : 2);
      const double side = rng.Uniform() < 0.5 ? -1.0 : 1.0;
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      (*p)[axis] = side * h[axis];
      (*p)[a1] = h[a1] * rng.Symmetric();
      (*p)[a2] = h[a2] * rng.Symmetric();
      *n = Vec3::Zero();
      (*n)[axis] = side;
      return;
    }
    case EShape::Sphere: {
      *n = UnitSphere(rng);
      *p = s.radius * *n;
      return;
    }
    case EShape::Ellipsoid: {
      // the area element scales by abc |D^-1 u| over the unit sphere's: accept in proportion
      const Vec3& e = s.semi_axes;
      const double min_axis = e.minCoeff();
      for (;;) {
        const Vec3 u = UnitSphere(rng);
        const double accept = min_axis * std::sqrt(Norm2(u.cwiseQuotient(e)));
        if (rng.Uniform() < accept) {
          *p = u.cwiseProduct(e);
          const Vec3 g = p->cwiseQuotient(e.cwiseProduct(e));
          *n = g / std::sqrt(Norm2(g));
          return;
        }
      }
    }
    case EShape::Capsule:
    case EShape::Cylinder: {
      const double r = s.radius, l = s.half_length;
      const double side_area = 4.0 * kPi * r * l;
      const double cap_area = s.type == EShape::Capsule ? 4.0 * kPi * r * r : 2.0 * kPi * r * r;
      if (rng.Uniform() * (side_area + cap_area) < side_area) {
        const Eigen::Vector2d c = UnitCircle(rng);
        *p = Vec3(r * c.x(), r * c.y(), l * rng.Symmetric());
        *n = Vec3(c.x(), c.y(), 0.0);
      } else if (s.type == EShape::Capsule) {
        *n = UnitSphere(rng);
        *p = r * *n + Vec3(0, 0, n->z() >= 0 ? l : -l);
      } else {
        const Eigen::Vector2d d = UnitDisk(rng);
        const double side = rng.Uniform() < 0.5 ? -1.0 : 1.0;
        *p = Vec3(r * d.x(), r * d.y(), side * l);
        *n = Vec3(0, 0, side);
      }
      return;
    }
    case EShape::Mesh:
      break;
  }
  *p = Vec3::Zero();
  *n = Vec3::UnitZ();
}

}  // namespace

const char* ToString(EMeshError e) {
  switch (e) {
    case EMeshError::None:
      return "ok";
    case EMeshError::Empty:
      return "empty mesh";
    case EMeshError::NotFinite:
      return "non-finite vertex coordinates";
    case EMeshError::IndexOutOfRange:
      return "vertex index out of range";
    case EMeshError::Degenerate:
      return "degenerate (zero-area triangles or no enclosed volume)";
    case EMeshError::Open:
      return "open surface";
    case EMeshError::NonManifold:
      return "non-manifold edges";
    case EMeshError::Inconsistent:
      return "inconsistent triangle orientation";
  }
  return "unknown mesh error";
}

double SignedVolume(const TriangleMesh& mesh) {
  // relative to the first vertex, for precision far from the origin
  if (mesh.vertices.empty()) return 0.0;
  const Vec3 o = mesh.vertices[0];
  const int nv = static_cast<int>(mesh.vertices.size());
  double six_v = 0.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= nv).any()) continue;
    const Vec3 a = mesh.vertices[t[0]] - o, b = mesh.vertices[t[1]] - o, c = mesh.vertices[t[2]] - o;
    six_v += a.dot(b.cross(c));
  }
  return six_v / 6.0;
}

double SurfaceArea(const TriangleMesh& mesh) {
  const int nv = static_cast<int>(mesh.vertices.size());
  double twice = 0.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= nv).any()) continue;
    const Vec3& a = mesh.vertices[t[0]];
    twice += (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a).norm();
  }
  return 0.5 * twice;
}

EMeshError ValidateAndOrientMesh(TriangleMesh* mesh) { return ValidateAndOrientMesh(mesh, nullptr); }

EMeshError ValidateAndOrientMesh(TriangleMesh* mesh, MeshCheckReport* report) {
  MeshCheckReport local;
  MeshCheckReport& rep = report ? *report : local;
  rep = MeshCheckReport();
  auto fail = [&](EMeshError e, int64_t count, int64_t first) {
    rep.error = e;
    rep.count = count;
    rep.first = first;
    return e;
  };
  if (!mesh || mesh->vertices.empty() || mesh->triangles.empty()) return fail(EMeshError::Empty, 0, -1);
  const std::vector<Vec3>& v = mesh->vertices;
  const int64_t nv = static_cast<int64_t>(v.size());
  const int64_t nt = static_cast<int64_t>(mesh->triangles.size());

  // finite vertices
  int64_t bad = 0, first = -1;
  for (int64_t i = 0; i < nv; ++i)
    if (!v[i].allFinite()) {
      if (first < 0) first = i;
      ++bad;
    }
  if (bad) return fail(EMeshError::NotFinite, bad, first);

  // indices in range
  for (int64_t t = 0; t < nt; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int idx = mesh->triangles[t][k];
      if (idx < 0 || idx >= nv) {
        if (first < 0) first = t;
        ++bad;
      }
    }
  }
  if (bad) return fail(EMeshError::IndexOutOfRange, bad, first);

  // zero-area triangles, relative to the bounding box
  Vec3 lo = v[0], hi = v[0];
  for (const Vec3& p : v) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double diag = (hi - lo).norm();
  const double min_twice_area = 1e-14 * diag * diag;
  for (int64_t t = 0; t < nt; ++t) {
    const Eigen::Vector3i& tri = mesh->triangles[t];
    const Vec3& a = v[tri[0]];
    const double twice = (v[tri[1]] - a).cross(v[tri[2]] - a).norm();
    if (!(twice > min_twice_area) || tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) {
      if (first < 0) first = t;
      ++bad;
    }
  }
  if (bad) return fail(EMeshError::Degenerate, bad, first);

  // edges: sort the 3T directed half-edges by undirected key, then by triangle
  struct HalfEdge {
    uint64_t key;
    int64_t tri;
    bool forward;  // lower vertex index first
  };
  std::vector<HalfEdge> edges;
  edges.reserve(static_cast<size_t>(3 * nt));
  for (int64_t t = 0; t < nt; ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = static_cast<uint32_t>(mesh->triangles[t][k]);
      const uint32_t b = static_cast<uint32_t>(mesh->triangles[t][(k + 1) % 3]);
      const uint64_t key = (static_cast<uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
      edges.push_back({key, t, a < b});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key < y.key || (x.key == y.key && x.tri < y.tri);
  });
  int64_t open = 0, non_manifold = 0, inconsistent = 0;
  int64_t first_open = -1, first_nm = -1, first_inc = -1;
  auto note = [](int64_t* f, int64_t t) {
    if (*f < 0 || t < *f) *f = t;
  };
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j].key == edges[i].key) ++j;
    const size_t n = j - i;
    if (n == 1) {
      ++open;
      note(&first_open, edges[i].tri);
    } else if (n > 2) {
      ++non_manifold;
      note(&first_nm, edges[i].tri);
    } else if (edges[i].forward == edges[i + 1].forward) {
      ++inconsistent;
      note(&first_inc, edges[i].tri);
    }
    i = j;
  }
  if (non_manifold) return fail(EMeshError::NonManifold, non_manifold, first_nm);
  if (open) return fail(EMeshError::Open, open, first_open);
  if (inconsistent) return fail(EMeshError::Inconsistent, inconsistent, first_inc);

  // orient outward; a closed surface that encloses nothing is degenerate
  const double volume = SignedVolume(*mesh);
  if (!(std::abs(volume) > 1e-12 * diag * diag * diag)) return fail(EMeshError::Degenerate, 0, -1);
  if (volume < 0) {
    for (Eigen::Vector3i& t : mesh->triangles) std::swap(t[1], t[2]);
    rep.flipped = true;
  }
  rep.volume = std::abs(volume);
  rep.error = EMeshError::None;
  return EMeshError::None;
}

double SurfaceArea(const ShapeDesc& shape) {
  if (!ValidShape(shape)) return 0.0;
  switch (shape.type) {
    case EShape::Box: {
      const Vec3& h = shape.half_extents;
      return 8.0 * (h.x() * h.y() + h.y() * h.z() + h.z() * h.x());
    }
    case EShape::Sphere:
      return 4.0 * kPi * shape.radius * shape.radius;
    case EShape::Ellipsoid: {
      // S = 4 pi abc R_G(a^-2, b^-2, c^-2)
      const Vec3& e = shape.semi_axes;
      const double abc = e.x() * e.y() * e.z();
      return 4.0 * kPi * abc *
             CarlsonRG(1.0 / (e.x() * e.x()), 1.0 / (e.y() * e.y()), 1.0 / (e.z() * e.z()));
    }
    case EShape::Capsule:
      return 4.0 * kPi * shape.radius * shape.radius + 4.0 * kPi * shape.radius * shape.half_length;
    case EShape::Cylinder:
      return 2.0 * kPi * shape.radius * shape.radius + 4.0 * kPi * shape.radius * shape.half_length;
    case EShape::Mesh:
      break;
  }
  return 0.0;
}

double AnalyticDistance(const ShapeDesc& shape, const Vec3& p, Vec3* normal) {
  if (!ValidShape(shape) || !p.allFinite()) {
    if (normal) *normal = Vec3::Zero();
    return kNaN;
  }
  switch (shape.type) {
    case EShape::Box: {
      const Vec3& h = shape.half_extents;
      const Vec3 q = p.cwiseAbs() - h;
      const Vec3 sign(p.x() < 0 ? -1.0 : 1.0, p.y() < 0 ? -1.0 : 1.0, p.z() < 0 ? -1.0 : 1.0);
      if ((q.array() > 0).any()) {
        // outside: to the nearest point of the clamped box
        const Vec3 out = q.cwiseMax(0.0);
        const double d = out.norm();
        if (normal) *normal = out.cwiseProduct(sign) / d;
        return d;
      }
      // inside or on the surface: the nearest face (first axis on ties)
      int axis = 0;
      for (int k = 1; k < 3; ++k)
        if (q[k] > q[axis]) axis = k;
      if (normal) {
        *normal = Vec3::Zero();
        (*normal)[axis] = sign[axis];
      }
      return q[axis];
    }
    case EShape::Sphere: {
      const double n = p.norm();
      if (normal) *normal = n > 0 ? Vec3(p / n) : Vec3::UnitZ();
      return n - shape.radius;
    }
    case EShape::Ellipsoid:
      return EllipsoidDistance(shape.semi_axes, p, normal);
    case EShape::Capsule: {
      const double l = shape.half_length;
      const Vec3 v = p - Vec3(0, 0, std::clamp(p.z(), -l, l));
      const double n = v.norm();
      if (normal) *normal = n > 0 ? Vec3(v / n) : Vec3::UnitX();
      return n - shape.radius;
    }
    case EShape::Cylinder: {
      const double rho = std::hypot(p.x(), p.y());
      const double dr = rho - shape.radius;
      const double dz = std::abs(p.z()) - shape.half_length;
      const double zs = p.z() < 0 ? -1.0 : 1.0;
      const Vec3 radial = rho > 0 ? Vec3(p.x() / rho, p.y() / rho, 0.0) : Vec3::UnitX();
      if (dr > 0 && dz > 0) {
        // outside the rim
        const double d = std::hypot(dr, dz);
        if (normal) *normal = (dr * radial + Vec3(0, 0, dz * zs)) / d;
        return d;
      }
      if (normal) *normal = dr >= dz ? radial : Vec3(0, 0, zs);
      return std::max(dr, dz);
    }
    case EShape::Mesh:
      break;
  }
  if (normal) *normal = Vec3::Zero();
  return kNaN;
}

namespace {

// m area-uniform random points on a valid shape
void ShapeCandidates(const ShapeDesc& shape, size_t m, uint64_t seed, std::vector<Vec3>* pos, std::vector<Vec3>* nrm) {
  Rng rng(seed);
  pos->resize(m);
  nrm->resize(m);
  for (size_t i = 0; i < m; ++i) ShapeCandidate(shape, rng, &(*pos)[i], &(*nrm)[i]);
}

// m area-uniform random points on a mesh; false (nothing written) when the mesh is
// empty, not finite, badly indexed or has no area; `area` gets its area
bool MeshCandidates(const TriangleMesh& mesh, size_t m, uint64_t seed, std::vector<Vec3>* pos,
                    std::vector<Vec3>* nrm, double* area) {
  if (mesh.vertices.empty() || mesh.triangles.empty()) return false;
  const int nv = static_cast<int>(mesh.vertices.size());
  for (const Vec3& p : mesh.vertices)
    if (!p.allFinite()) return false;

  // per-triangle area (cumulative) and unit normal
  const size_t nt = mesh.triangles.size();
  std::vector<double> cum(nt);
  std::vector<Vec3> face_normal(nt);
  double total = 0.0;
  for (size_t t = 0; t < nt; ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    if ((tri.array() < 0).any() || (tri.array() >= nv).any()) return false;
    const Vec3& a = mesh.vertices[tri[0]];
    const Vec3 c = (mesh.vertices[tri[1]] - a).cross(mesh.vertices[tri[2]] - a);
    const double twice = std::sqrt(Norm2(c));
    face_normal[t] = twice > 0 ? Vec3(c / twice) : Vec3::UnitZ();
    total += 0.5 * twice;
    cum[t] = total;
  }
  if (!(total > 0) || !std::isfinite(total)) return false;

  // triangle by area, then uniform barycentric coordinates
  Rng rng(seed);
  pos->resize(m);
  nrm->resize(m);
  for (size_t i = 0; i < m; ++i) {
    const double u = rng.Uniform() * total;
    size_t t = static_cast<size_t>(std::upper_bound(cum.begin(), cum.end(), u) - cum.begin());
    if (t >= nt) t = nt - 1;
    while (t > 0 && cum[t] == cum[t - 1]) --t;  // never a zero-area triangle
    double r1 = rng.Uniform(), r2 = rng.Uniform();
    if (r1 + r2 > 1.0) {
      r1 = 1.0 - r1;
      r2 = 1.0 - r2;
    }
    const Eigen::Vector3i& tri = mesh.triangles[t];
    const Vec3& a = mesh.vertices[tri[0]];
    (*pos)[i] = a + r1 * (mesh.vertices[tri[1]] - a) + r2 * (mesh.vertices[tri[2]] - a);
    (*nrm)[i] = face_normal[t];
  }
  *area = total;
  return true;
}

bool ClearOutput(PointCloud* out) {
  if (!out) return false;
  out->positions.clear();
  out->normals.clear();
  return true;
}

}  // namespace

bool SampleShape(const ShapeDesc& shape, int count, uint64_t seed, PointCloud* out) {
  if (!ClearOutput(out) || count < 4 || count > kMaxSampleCount || !ValidShape(shape)) return false;
  const double area = SurfaceArea(shape);
  if (!(area > 0) || !std::isfinite(area)) return false;
  std::vector<Vec3> pos, nrm;
  ShapeCandidates(shape, static_cast<size_t>(count) * kCandidateFactor, seed, &pos, &nrm);
  EliminateInto(pos, nrm, area, count, out);
  return static_cast<int>(out->size()) == count;
}

bool SampleMesh(const TriangleMesh& mesh, int count, uint64_t seed, PointCloud* out) {
  if (!ClearOutput(out) || count < 4 || count > kMaxSampleCount) return false;
  std::vector<Vec3> pos, nrm;
  double area = 0;
  if (!MeshCandidates(mesh, static_cast<size_t>(count) * kCandidateFactor, seed, &pos, &nrm, &area)) return false;
  EliminateInto(pos, nrm, area, count, out);
  return static_cast<int>(out->size()) == count;
}

bool SampleShapeRandom(const ShapeDesc& shape, int count, uint64_t seed, PointCloud* out) {
  if (!ClearOutput(out) || count < 1 || count > kMaxSampleCount * kCandidateFactor || !ValidShape(shape)) return false;
  ShapeCandidates(shape, static_cast<size_t>(count), seed, &out->positions, &out->normals);
  return true;
}

bool SampleMeshRandom(const TriangleMesh& mesh, int count, uint64_t seed, PointCloud* out) {
  if (!ClearOutput(out) || count < 1 || count > kMaxSampleCount * kCandidateFactor) return false;
  double area = 0;
  return MeshCandidates(mesh, static_cast<size_t>(count), seed, &out->positions, &out->normals, &area);
}

double MeanSpacing(const PointCloud& cloud) {
  const std::vector<Vec3>& pts = cloud.positions;
  const size_t n = pts.size();
  if (n < 2) return 0.0;
  Vec3 lo = pts[0], hi = pts[0];
  for (const Vec3& p : pts) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec3 ext = hi - lo;
  const double diag = ext.norm();
  if (!std::isfinite(diag)) return kNaN;
  if (diag == 0) return 0.0;
  // first guess: the spacing of n points spread over the bounding box's surface
  const double box_area = 2.0 * (ext.x() * ext.y() + ext.y() * ext.z() + ext.z() * ext.x());
  double r0 = std::sqrt(std::max(box_area, diag * diag * 1e-6) / static_cast<double>(n));
  PointGrid grid;
  grid.Build(pts, r0);
  std::vector<int> buf;
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double best2 = std::numeric_limits<double>::infinity();
    for (double r = r0;; r *= 2.0) {
      buf.clear();
      grid.Query(pts[i], r, &buf);
      for (int j : buf)
        if (j != static_cast<int>(i)) best2 = std::min(best2, (pts[j] - pts[i]).squaredNorm());
      if (best2 < std::numeric_limits<double>::infinity() || r > 2.0 * diag) break;
    }
    sum += std::sqrt(best2);
  }
  return sum / static_cast<double>(n);
}

}  // namespace gs
