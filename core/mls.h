// Point-based implicit surface (paper section 3.2): weighted least squares with
// a truncated Gaussian kernel theta(x) = exp(-x^2/h^2).
//   a(p) = sum theta_k p_k / sum theta_k                      (eq. 2)
//   n(p) = eigenvector of the smallest eigenvalue of B(p)     (eq. 3)
//   f(p) = n(p) . (a(p) - p)                                  (eq. 1)
// The projection operator follows the paper's reference [7] (Alexa et al.):
// a reference plane from (a, n), then, optionally, a weighted least-squares
// quadratic height field over that plane; the projection moves to the point of
// that quadric closest to the query and fits again there, until it settles: the
// result is the foot of the query on the surface, whatever the start.
//
// Every function works on a subset of a point set given by an index list, so
// that collision detection can restrict the surface to the points of a coupled
// sphere-tree node plus its border. Points and query are in the same frame.
#pragma once

#include "core/types.h"

namespace gs {

struct MlsParams {
  double bandwidth = 1e-3;    ///< kernel bandwidth h (m)
  double support = 2.5;       ///< kernel truncated beyond support * h
  int max_iterations = 4;     ///< projection iterations
  double tolerance = 1e-3;    ///< stop when a projection step moves less than tolerance * h
  bool quadric = true;        ///< false: plane MLS only (the paper's f); true: plus quadratic fit ([7])
};

/// Defaults measured to meet 1% of the spacing on curved surfaces at the paper's
/// density: h = 1.5 spacing, support 2.5 h, up to 4 iterations, with the quadric.
MlsParams RecommendedMlsParams(double spacing);

/// The local reference frame of the MLS surface at a query point.
struct MlsFit {
  Vec3 mean = Vec3::Zero();    ///< a(p)
  Vec3 normal = Vec3::Zero();  ///< n(p), oriented like the points' normals
  double weight_sum = 0.0;
  int neighbours = 0;          ///< points with non-zero weight
};

/// Fits a(p) and n(p) from the points idx[0..count). Returns false when fewer than
/// 3 points carry weight or the covariance is degenerate.
bool MlsPlaneFit(const Vec3* positions, const Vec3* normals, const int* idx, int count,
                 const Vec3& p, const MlsParams& params, MlsFit* out);

/// The paper's implicit function f(p) = n(p).(a(p) - p); NaN when the fit fails.
double MlsImplicit(const Vec3* positions, const Vec3* normals, const int* idx, int count,
                   const Vec3& p, const MlsParams& params);

struct MlsProjection {
  Vec3 point = Vec3::Zero();   ///< the projected point on the surface
  Vec3 normal = Vec3::Zero();  ///< outward unit normal there
  int iterations = 0;
  bool converged = false;
  bool far = false;  ///< stopped early: farther outside the surface than the caller asked about
  double outside = 0.0;  ///< when far: how far outside the surface the point is known to stand, at least (m)
};

/// The MLS surface near one point, cached: a quadratic height field
/// h c(u, v) over the tangent frame (origin, t1, t2, normal) of the weighted
/// least-squares fit there, in coordinates u, v in units of the bandwidth h.
/// Close to where it was fitted it is a good first guess of the projection.
struct MlsPatch {
  Vec3 origin = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  Vec3 t1 = Vec3::UnitX(), t2 = Vec3::UnitY();
  double h = 1.0;
  double c[6] = {0, 0, 0, 0, 0, 0};  ///< 1, u, v, uu, uv, vv
  /// The point of the patch straight below (or above) x along the normal.
  Vec3 Below(const Vec3& x) const {
    const Vec3 d = x - origin;
    const double u = d.dot(t1) / h, v = d.dot(t2) / h;
    const double g = c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v;
    return origin + (u * t1 + v * t2 + g * normal) * h;
  }
  /// The point of the patch closest to x (the point below x where x lies past
  /// the patch's centre of curvature).
  Vec3 Closest(const Vec3& x) const;
  /// The patch's unit normal at the point below x.
  Vec3 NormalBelow(const Vec3& x) const {
    const Vec3 d = x - origin;
    const double u = d.dot(t1) / h, v = d.dot(t2) / h;
    const double gu = c[1] + 2.0 * c[3] * u + c[4] * v, gv = c[2] + c[4] * u + 2.0 * c[5] * v;
    return (normal - gu * t1 - gv * t2).normalized();
  }
  /// The patch's shape operator at its origin (rest frame, 1/m): K v is how fast
  /// the outward normal turns per metre moved along the tangent v, positive where
  /// the surface bends away from its normal (convex). A sphere of radius R gives
  /// (I - n n^T) / R, a flat face 0.
  Mat3 Shape() const {
    return -(2.0 * c[3] * t1 * t1.transpose() + c[4] * (t1 * t2.transpose() + t2 * t1.transpose()) +
             2.0 * c[5] * t2 * t2.transpose()) / h;
  }
};

/// Fits the patch at p from the points idx[0..count) (the plane alone when the
/// quadric is ill-conditioned). Returns false when the plane fit fails.
bool MlsFitPatch(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& p,
                 const MlsParams& params, MlsPatch* out);

/// Projects p onto the MLS surface of the points idx[0..count): the point of the
/// surface closest to p, found by fitting the plane and quadric at the current
/// point and moving to the point of that quadric closest to p, until the move is
/// below tolerance * h (where p is beyond the quadric's centre of curvature, the
/// point straight below it is taken instead).
/// Returns false when a fit fails (too few weighted points). At most 512 points
/// within the kernel's support of a query take part in a fit.
bool MlsProject(const Vec3* positions, const Vec3* normals, const int* idx, int count,
                const Vec3& p, const MlsParams& params, MlsProjection* out);
/// The same projection of x, with the fits starting at `start` instead of x:
/// a start already near x's foot on the surface saves fits.
bool MlsProjectFrom(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                    const Vec3& start, const MlsParams& params, MlsProjection* out);
/// One step of that projection: fits at q and gives the point of the fitted
/// surface closest to x and the normal there. False when the fit fails.
bool MlsProjectStep(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                    const Vec3& q, const MlsParams& params, Vec3* next, Vec3* normal);

}  // namespace gs
