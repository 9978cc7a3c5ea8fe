// The eq. 8 interpolation of a Boussinesq body: a contact point between control
// points must see the dent the control points are in. Shepard weights (a positive
// weighted mean) read a dent u = d - r^2 / 2R too shallow by sum w |x|^2 / 2R, which
// made a rigid sphere on a Boussinesq flat 2-5 % too shallow and its exponent 1.470
// instead of 1.495; the weights now reproduce constant, linear and |x|^2 fields.
#include "core/deformation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace gs {
namespace {

constexpr double kSpacing = 1e-3;

// control points on the plane z = 0, a square lattice jittered by 20 % of the spacing
std::vector<Vec3> JitteredLattice(int half) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.2 * kSpacing, 0.2 * kSpacing);
  std::vector<Vec3> cp;
  for (int i = -half; i <= half; ++i)
    for (int j = -half; j <= half; ++j) cp.emplace_back(i * kSpacing + jitter(rng), j * kSpacing + jitter(rng), 0.0);
  return cp;
}

int Nearest(const std::vector<Vec3>& cp, const Vec3& p) {
  int best = 0;
  for (int i = 1; i < static_cast<int>(cp.size()); ++i)
    if ((cp[i] - p).squaredNorm() < (cp[best] - p).squaredNorm()) best = i;
  return best;
}

DeformableModel Build(EDeformation model, const std::vector<Vec3>& cp) {
  DeformationParams params;
  params.model = model;
  params.young_modulus = 1e5;
  params.poisson_ratio = 0.45;
  params.stiffness = 300.0;
  params.influence_radius = 4 * kSpacing;
  DeformableModel m;
  m.Build(cp, kSpacing * kSpacing, params, 0.01);
  return m;
}

// the interpolated value of a field given at the control points, at p
template <class Field>
double Interpolated(const DeformableModel& m, const std::vector<Vec3>& cp, const Vec3& p, Field field) {
  int idx[6];
  double w[6];
  const int n = m.Interpolate(p, Nearest(cp, p), idx, w, 6);
  double sum = 0.0, value = 0.0;
  for (int k = 0; k < n; ++k) {
    sum += w[k];
    value += w[k] * field(cp[idx[k]]);
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
  return value;
}

TEST(Deformation, BoussinesqInterpolationReadsASphericalDentExactly) {
  const std::vector<Vec3> cp = JitteredLattice(6);
  const DeformableModel m = Build(EDeformation::Boussinesq, cp);
  const double R = 0.02, d = 1e-3;
  // a dent under a sphere of radius R, tilted a little: constant, linear and r^2 terms
  auto dent = [&](const Vec3& x) { return d - x.head<2>().squaredNorm() / (2 * R) + 0.01 * x.x() - 0.02 * x.y(); };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> at(-2.5 * kSpacing, 2.5 * kSpacing);
  double worst = 0.0;
  for (int i = 0; i < 200; ++i) {
    const Vec3 p(at(rng), at(rng), 0.0);
    worst = std::max(worst, std::abs(Interpolated(m, cp, p, dent) - dent(p)));
  }
  // Shepard weights miss by sum w |x|^2 / 2R: up to ~0.4 spacing^2 / R = 20 um here
  EXPECT_LT(worst, 1e-12) << "the dent read between control points, worst error (m)";
}

TEST(Deformation, GaussianInterpolationStaysAPositiveMean) {
  // the paper's local model keeps eq. 8 as written: positive gaussian weights
  const std::vector<Vec3> cp = JitteredLattice(4);
  const DeformableModel m = Build(EDeformation::Gaussian, cp);
  int idx[6];
  double w[6];
  const Vec3 p(0.3 * kSpacing, -0.4 * kSpacing, 0.0);
  const int n = m.Interpolate(p, Nearest(cp, p), idx, w, 6);
  ASSERT_EQ(n, 6);
  for (int k = 0; k < n; ++k) EXPECT_GT(w[k], 0.0);
}

}  // namespace
}  // namespace gs
