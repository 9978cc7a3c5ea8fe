// Point-based implicit surface (paper section 3.2): weighted least squares with
// a truncated Gaussian kernel theta(x) = exp(-x^2/h^2).
//   a(p) = sum theta_k p_k / sum theta_k                      (eq. 2)
//   n(p) = eigenvector of the smallest eigenvalue of B(p)     (eq. 3)
//   f(p) = n(p) . (a(p) - p)                                  (eq. 1)
// The projection operator follows the paper's reference [7] (Alexa et al.):
// a reference plane from (a, n), then, optionally, a weighted least-squares
// quadratic height field over that plane, iterated at the projected point.
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
};

/// Projects p onto the MLS surface of the points idx[0..count).
/// Returns false when a fit fails (too few weighted points).
bool MlsProject(const Vec3* positions, const Vec3* normals, const int* idx, int count,
                const Vec3& p, const MlsParams& params, MlsProjection* out);

}  // namespace gs
