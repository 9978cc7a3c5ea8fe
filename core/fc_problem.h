// A frictional contact problem with an explicit sparse Delassus matrix (the
// FCLIB "local" problem): find r in the cones with u = W r + q, De Saxce's
// complementarity per contact (local_solver.h). The simulator's own step never
// forms W; this form is for problems read from files, problems exported from a
// step, and generated benchmark problems. Solved by the same NSGS (nsgs.h).
#pragma once

#include <Eigen/SparseCore>
#include <vector>

#include "core/nsgs.h"

namespace gs {

using SparseRowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

struct FcProblem {
  int contacts = 0;
  SparseRowMatrix W;     ///< 3n x 3n, per contact normal first then two tangents
  Eigen::VectorXd q;     ///< 3n
  Eigen::VectorXd mu;    ///< n
};

/// What is wrong with a problem (dimensions, non-finite values, negative mu,
/// a diagonal block that is not positive), or an empty string.
const char* CheckFcProblem(const FcProblem& p);

/// The NSGS operator on an explicit W: u_c = q_c + sum_j W_cj r_j over the
/// non-zero 3x3 blocks of block row c, stored contiguously (block CSR: column
/// block indices and 3x3 column-major blocks), built once from W.
class SparseDelassus {
 public:
  explicit SparseDelassus(const FcProblem& p);
  int NumContacts() const { return p_.contacts; }
  Mat3 DiagonalBlock(int c) const { return diag_[c]; }
  double Mu(int c) const { return p_.mu[c]; }
  double FreeNormSquared() const { return p_.q.squaredNorm(); }
  Vec3 Velocity(int c, const Vec3* r) const {
    double u0 = p_.q[3 * c], u1 = p_.q[3 * c + 1], u2 = p_.q[3 * c + 2];
    const int end = row_start_[c + 1];
    const double* b = blocks_.data() + 9 * static_cast<size_t>(row_start_[c]);
    for (int k = row_start_[c]; k < end; ++k, b += 9) {
      const double* x = r[col_[k]].data();
      u0 += b[0] * x[0] + b[3] * x[1] + b[6] * x[2];
      u1 += b[1] * x[0] + b[4] * x[1] + b[7] * x[2];
      u2 += b[2] * x[0] + b[5] * x[1] + b[8] * x[2];
    }
    return Vec3(u0, u1, u2);
  }
  void ApplyDelta(int, const Vec3&) {}

 private:
  const FcProblem& p_;
  std::vector<Mat3> diag_;
  std::vector<int> row_start_, col_;
  std::vector<double> blocks_;
};

/// Solver choice for explicit problems: NSGS with conjugate directions and
/// extrapolation every 50 sweeps.
struct FcSolveParams {
  NsgsParams nsgs = [] {
    NsgsParams p;
    p.extrapolate_every = 50;
    p.conjugate = true;
    return p;
  }();
};

struct FcSolveResult {
  NsgsResult nsgs;
  double seconds = 0.0;
};

/// Solves from the forces in *r (resized to 3n and zeroed when the size differs).
FcSolveResult SolveFcProblem(const FcProblem& p, const FcSolveParams& params, Eigen::VectorXd* r);

/// The Siconos error of r for the problem.
double FcError(const FcProblem& p, const Eigen::VectorXd& r);
/// The scaled measure of r (core/nsgs.h, EStopMeasure::Scaled), gap_scale in m.
double FcScaledError(const FcProblem& p, const Eigen::VectorXd& r, double gap_scale);

/// A random rigid-body problem: boxes on a grid in stacks of `layers`, each
/// resting on the one below (the bottom one on the ground) through 4 corner
/// contacts, W = H M^-1 H^T, mu uniform in [0.1, 1], q = H v of a falling,
/// slightly spinning state. Deterministic in `seed`.
FcProblem RandomRigidProblem(int contacts, int layers, uint64_t seed);

}  // namespace gs
