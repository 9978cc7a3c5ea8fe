#include "core/deformation.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "core/point_grid.h"
#include "core/sym_eigen3.h"

namespace gs {
namespace {

// Turns the Shepard weights w (normalised gaussian weights of the `count` control points
// idx around the surface point p) into weights that reproduce exactly, at p, any field
// a + b.x + c |x|^2 of the tangent-plane offset x: a moving least-squares fit of that
// basis with the gaussian weights, evaluated at p. Shepard weights are positive, so
// they average a displacement field that bends (a dent under a sphere: u = d - r^2/2R)
// to below its value at p, by sum_k w_k |x_k|^2 / 2R: the interpolated dent is
// shallower than the control points' and the contact stiffer. Leaves w unchanged
// (returns false) when the points do not determine the fit.
bool CurvatureExactWeights(const Vec3& p, const std::vector<Vec3>& cp, const int* idx, double* w, int count,
                           double spacing) {
  Mat3 cov = Mat3::Zero();
  for (int k = 0; k < count; ++k) {
    const Vec3 d = cp[idx[k]] - p;
    cov += w[k] * d * d.transpose();
  }
  const Vec3 n = SmallestEigenvector(cov);
  const Vec3 t1 = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized();
  const Vec3 t2 = n.cross(t1);
  const double inv_h = 1.0 / spacing;
  Eigen::Matrix<double, 4, 6> basis;
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  for (int k = 0; k < count; ++k) {
    const Vec3 d = (cp[idx[k]] - p) * inv_h;
    const double x = d.dot(t1), y = d.dot(t2);
    basis.col(k) = Eigen::Vector4d(1.0, x, y, x * x + y * y);
    m += w[k] * basis.col(k) * basis.col(k).transpose();
  }
  const Eigen::LDLT<Eigen::Matrix4d> ldlt(m);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-6)) return false;
  const Eigen::Vector4d a = ldlt.solve(Eigen::Vector4d::UnitX());
  double out[6], spread = 0.0;
  for (int k = 0; k < count; ++k) {
    out[k] = w[k] * basis.col(k).dot(a);
    spread += std::abs(out[k]);
  }
  // a fit that needs large opposing weights extrapolates: keep the averaging
  if (!std::isfinite(spread) || spread > 3.0) return false;
  for (int k = 0; k < count; ++k) w[k] = out[k];
  return true;
}

}  // namespace

void DeformableModel::Build(const std::vector<Vec3>& control_points, double area_per_point,
                            const DeformationParams& params, double dt) {
  params_ = params;
  cp_ = control_points;
  inf_start_.assign(1, 0);
  inf_idx_.clear();
  inf_phi_.clear();
  self_phi_.clear();
  nb_start_.assign(1, 0);
  nb_idx_.clear();
  relax_.clear();
  spacing_ = std::sqrt(std::max(area_per_point, 0.0));
  if (params.model == EDeformation::Rigid || cp_.empty()) {
    cp_.clear();
    return;
  }
  const int n = static_cast<int>(cp_.size());
  PointGrid grid;
  grid.Build(cp_, std::max(spacing_, 1e-9));
  std::vector<int> nbrs;
  relax_.resize(n);

  // influence: phi_ij for every i near j, j itself first
  const double nu2 = 1.0 - params.poisson_ratio * params.poisson_ratio;
  for (int j = 0; j < n; ++j) {
    nbrs.clear();
    double self = 0.0, cutoff = 0.0, scale = 1.0;
    if (params.model == EDeformation::Gaussian) {
      const double c = 1.0 / (params.stiffness + params.damping / dt);
      self = c;
      cutoff = 3.0 * params.influence_radius;
      relax_[j] = c * params.damping / dt;
    } else {
      const double a = std::sqrt(area_per_point / M_PI);
      const double c0 = 2.0 * nu2 / (M_PI * params.young_modulus * a);  // static self compliance
      const double k = 1.0 / c0;
      scale = k / (k + params.damping / dt);
      self = c0 * scale;
      // The half-space kernel decays as 1/x and never vanishes: truncating it drops the
      // displacement that a force causes beyond the cutoff. Within one contact patch
      // every pair of points must stay inside the cutoff, or the patch's rim sinks too
      // little under the load at its centre, comes into contact too early and the patch
      // grows wider and stiffer than Hertz's (a sphere of R = 2 cm pressed 1.8 mm deep:
      // a 6 mm patch radius against a cutoff of 8 spacings = 8 mm gave a 11% too wide
      // patch and 8% too little indentation). So the scene's influence radius, when
      // given, is the truncation radius; it should exceed the largest patch diameter.
      cutoff = params.influence_radius > 0.0 ? std::max(params.influence_radius, spacing_) : 8.0 * spacing_;
      relax_[j] = (params.damping / dt) / (k + params.damping / dt);
    }
    grid.Query(cp_[j], cutoff, &nbrs);
    std::sort(nbrs.begin(), nbrs.end());
    inf_idx_.push_back(j);
    inf_phi_.push_back(self);
    self_phi_.push_back(self);
    for (int i : nbrs) {
      if (i == j) continue;
      const double x = (cp_[i] - cp_[j]).norm();
      double phi;
      if (params.model == EDeformation::Gaussian) {
        const double rho = params.influence_radius;
        phi = std::exp(-(x * x) / (rho * rho)) * self;
      } else {
        phi = std::min(nu2 / (M_PI * params.young_modulus * std::max(x, 1e-12)) * scale, self);
      }
      inf_idx_.push_back(i);
      inf_phi_.push_back(phi);
    }
    inf_start_.push_back(static_cast<int>(inf_idx_.size()));
    cutoff_ = cutoff;
    scale_ = scale;
    self_ = self;
  }

  // interpolation candidates: control points within 2.5 spacings of each leaf
  for (int j = 0; j < n; ++j) {
    nbrs.clear();
    grid.Query(cp_[j], 2.5 * spacing_, &nbrs);
    std::sort(nbrs.begin(), nbrs.end());
    nb_idx_.insert(nb_idx_.end(), nbrs.begin(), nbrs.end());
    nb_start_.push_back(static_cast<int>(nb_idx_.size()));
  }
}

double DeformableModel::Kernel(int i, int j) const {
  if (i == j) return self_;
  const double x = (cp_[i] - cp_[j]).norm();
  if (x > cutoff_) return 0.0;
  if (params_.model == EDeformation::Gaussian) {
    const double rho = params_.influence_radius;
    return std::exp(-(x * x) / (rho * rho)) * self_;
  }
  const double nu2 = 1.0 - params_.poisson_ratio * params_.poisson_ratio;
  return std::min(nu2 / (M_PI * params_.young_modulus * std::max(x, 1e-12)) * scale_, self_);
}

int DeformableModel::Interpolate(const Vec3& p, int near, int* idx, double* w, int max) const {
  if (!enabled() || near < 0 || near >= size() || max <= 0) return 0;
  // gaussian weights with the control spacing as bandwidth (eq. 8) of the `max`
  // nearest candidates (the heaviest weights), chosen by squared distance so that
  // only the kept ones pay for an exp (w holds squared distances until then)
  const double h2 = spacing_ * spacing_;
  int count = 0;
  double sum = 0.0;
  for (int k = nb_start_[near]; k < nb_start_[near + 1]; ++k) {
    const int i = nb_idx_[k];
    const double d2 = (cp_[i] - p).squaredNorm();
    if (count < max) {
      idx[count] = i;
      w[count] = d2;
      ++count;
    } else {
      int farthest = 0;
      for (int m = 1; m < count; ++m)
        if (w[m] > w[farthest]) farthest = m;
      if (d2 < w[farthest]) {
        idx[farthest] = i;
        w[farthest] = d2;
      }
    }
  }
  for (int m = 0; m < count; ++m) w[m] = std::exp(-w[m] / h2);
  for (int m = 0; m < count; ++m) sum += w[m];
  if (!(sum > 1e-300)) {
    idx[0] = near;
    w[0] = 1.0;
    return 1;
  }
  for (int m = 0; m < count; ++m) w[m] /= sum;
  if (params_.model == EDeformation::Boussinesq && count >= 5 && count <= 6)
    CurvatureExactWeights(p, cp_, idx, w, count, spacing_);
  return count;
}

}  // namespace gs
