// The deformable half of a quasi-rigid body (paper section 3.5.2): compliance on
// the control points (the sphere-tree leaf centres).
//
// A force F_j at control point j displaces control point i by
//   u_i = phi(|c_i - c_j|) F_j                                      (eq. 13)
// with, per model:
// - gaussian (the paper's local model, eq. 14): phi = gauss(x) C_j,
//   gauss(x) = exp(-x^2/rho^2) truncated at 3 rho, C_j = (K + D/dt)^-1;
// - boussinesq (Pauly et al. 2004, the paper's [9]): an elastic half-space,
//   phi = (1 - nu^2) / (pi E x) for i != j and, for the point's own patch of
//   area A_j (a disc of radius a_j), the mean-pressure value 2 (1 - nu^2) / (pi E a_j);
//   truncated at the influence radius (default 8 control-point spacings). Damping scales it by K/(K + D/dt)
//   with K the point's own stiffness. The kernel is isotropic (the Cerruti
//   tangential terms are neglected).
// Kelvin-Voigt with implicit Euler makes the free displacement a relaxation of
// the previous one: u_free = (C D/dt) u_prev, so deformation decays when
// contact ends.
// The displacement of a surface point p is the kernel-weighted mean of the
// control displacements (eq. 8).
#pragma once

#include "core/types.h"

namespace gs {

enum class EDeformation { Rigid, Gaussian, Boussinesq };

struct DeformationParams {
  EDeformation model = EDeformation::Rigid;
  double stiffness = 0.0;         ///< gaussian: K per control point (N/m)
  double damping = 0.0;           ///< D per control point (N s/m)
  double influence_radius = 0.0;  ///< gaussian: rho (m); boussinesq: truncation radius (0: 8 spacings)
  double young_modulus = 0.0;     ///< boussinesq: E (Pa)
  double poisson_ratio = 0.0;     ///< boussinesq: nu
};

class DeformableModel {
 public:
  /// Precomputes the sparse influence and interpolation neighbourhoods.
  /// `area_per_point` is the surface area each control point stands for (m^2).
  void Build(const std::vector<Vec3>& control_points, double area_per_point, const DeformationParams& params,
             double dt);

  bool enabled() const { return params_.model != EDeformation::Rigid && !cp_.empty(); }
  const DeformationParams& params() const { return params_; }
  int size() const { return static_cast<int>(cp_.size()); }

  /// Control points influenced by a force at j, with phi_ij (m/N), j itself first.
  int Influence(int j, const int** idx, const double** phi) const {
    *idx = inf_idx_.data() + inf_start_[j];
    *phi = inf_phi_.data() + inf_start_[j];
    return inf_start_[j + 1] - inf_start_[j];
  }
  /// Displacement at j per unit force at j (m/N).
  double SelfCompliance(int j) const { return self_phi_[j]; }
  /// u_free = Relaxation(j) * u_prev.
  double Relaxation(int j) const { return relax_[j]; }

  /// phi_ij evaluated directly from the kernel (0 beyond the cutoff), m/N.
  double Kernel(int i, int j) const;

  /// Eq. 8 weights of the control points around point p (rest frame) near leaf
  /// `near`: writes at most `max` (index, weight) pairs, weights summing to 1.
  int Interpolate(const Vec3& p, int near, int* idx, double* w, int max) const;

  double spacing() const { return spacing_; }

 private:
  DeformationParams params_;
  std::vector<Vec3> cp_;
  std::vector<int> inf_start_, inf_idx_;
  std::vector<double> inf_phi_;
  /// each point's own phi_jj (the first of its influence), packed: the contact space
  /// reads it for every contact, and inf_phi_ is megabytes on a dense body
  std::vector<double> self_phi_;
  std::vector<int> nb_start_, nb_idx_;  // interpolation candidates per leaf
  std::vector<double> relax_;
  double spacing_ = 0.0;
  double cutoff_ = 0.0;
  double scale_ = 1.0;   // boussinesq damping scale
  double self_ = 0.0;    // self compliance (all points alike)
};

}  // namespace gs
