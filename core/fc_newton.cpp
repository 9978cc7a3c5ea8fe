#include "core/fc_newton.h"

#include <Eigen/LU>
#include <Eigen/SparseLU>
#include <algorithm>
#include <chrono>
#include <cmath>

namespace gs {

const char* FcStopName(EFcStop stop) {
  switch (stop) {
    case EFcStop::Converged: return "converged";
    case EFcStop::IterationCap: return "iteration cap reached";
    case EFcStop::TimeCap: return "time budget reached";
    case EFcStop::Outpaced: return "outpaced (the other method was converging faster)";
    case EFcStop::Stagnated: return "stagnated (no progress)";
    case EFcStop::LineSearchFailed: return "line search failed (no step reduces the Alart-Curnier residual)";
    case EFcStop::Diverged: return "forces grow without bound: the problem is likely infeasible";
  }
  return "unknown";
}

namespace {

using ColMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// W r and the factorisation of J = B W + D (B, D block diagonal, 3x3 per
// contact): Eigen's sparse LU (pattern analysed once) when W is sparse (piles,
// stacks), a dense partial-pivoting LU when W is mostly filled (the contacts of
// one deformable body all couple, and a sparse LU of a full matrix is many times
// slower than a dense one).
class LinearAlgebra {
 public:
  explicit LinearAlgebra(const FcProblem& p) : contacts_(p.contacts) {
    const double m = 3.0 * p.contacts;
    dense_ = p.W.nonZeros() > kDenseFill * m * m;
    if (dense_) {
      Wd_ = Eigen::MatrixXd(p.W);
      return;
    }
    W_ = p.W;
    std::vector<Eigen::Triplet<double>> trip;  // every entry of every diagonal block: a fixed pattern
    trip.reserve(9 * static_cast<size_t>(p.contacts));
    for (int c = 0; c < p.contacts; ++c)
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) trip.emplace_back(3 * c + i, 3 * c + j, 1.0);
    B_.resize(3 * p.contacts, 3 * p.contacts);
    B_.setFromTriplets(trip.begin(), trip.end());
    D_ = B_;
  }

  bool Dense() const { return dense_; }

  void Multiply(const Eigen::VectorXd& r, Eigen::VectorXd* u) const {
    if (dense_) u->noalias() = Wd_ * r;
    else u->noalias() = W_ * r;
  }

  /// Factorises B W + D; false when the factorisation fails.
  bool Factorize(const std::vector<Mat3>& B, const std::vector<Mat3>& D) {
    return dense_ ? FactorizeDense(B, D) : FactorizeSparse(B, D);
  }

  void Solve(const Eigen::VectorXd& rhs, Eigen::VectorXd* x) {
    if (dense_) *x = dense_lu_.solve(rhs);
    else *x = lu_.solve(rhs);
  }

 private:
  static constexpr double kDenseFill = 0.1;

  bool FactorizeDense(const std::vector<Mat3>& B, const std::vector<Mat3>& D) {
    J_.resize(Wd_.rows(), Wd_.cols());
    for (int c = 0; c < contacts_; ++c) {
      J_.middleRows<3>(3 * c).noalias() = B[c] * Wd_.middleRows<3>(3 * c);
      J_.block<3, 3>(3 * c, 3 * c) += D[c];
    }
    dense_lu_.compute(J_);
    return true;  // a singular J gives non-finite steps, which the line search refuses
  }

  bool FactorizeSparse(const std::vector<Mat3>& B, const std::vector<Mat3>& D) {
    for (int c = 0; c < contacts_; ++c) {
      SetBlock(&B_, c, B[c]);
      SetBlock(&D_, c, D[c]);
    }
    Js_ = B_ * W_;
    Js_ += D_;
    if (!analysed_) {
      lu_.analyzePattern(Js_);
      analysed_ = true;
    }
    lu_.factorize(Js_);
    return lu_.info() == Eigen::Success;
  }

  static void SetBlock(ColMatrix* M, int c, const Mat3& blk) {
    for (int j = 0; j < 3; ++j) {
      // column 3c + j holds rows 3c, 3c + 1, 3c + 2 contiguously
      double* v = M->valuePtr() + M->outerIndexPtr()[3 * c + j];
      for (int i = 0; i < 3; ++i) v[i] = blk(i, j);
    }
  }

  int contacts_;
  bool dense_ = false, analysed_ = false;
  Eigen::MatrixXd Wd_, J_;
  Eigen::PartialPivLU<Eigen::MatrixXd> dense_lu_;
  ColMatrix W_, B_, D_, Js_;
  Eigen::SparseLU<ColMatrix, Eigen::COLAMDOrdering<int>> lu_;
};

// The Alart-Curnier function of a problem with W + sigma I and free velocity
// q - sigma centre, and its Jacobian's blocks: J = A + B (W + sigma I).
class AlartCurnier {
 public:
  explicit AlartCurnier(const FcProblem& p)
      : p_(p), la_(p), rho_(p.contacts), B_(p.contacts), D_(p.contacts), u_(3 * p.contacts) {
    const int m = 3 * p.contacts;
    double trace = 0.0;
    for (int c = 0; c < p.contacts; ++c) {
      const double d = std::max({p.W.coeff(3 * c, 3 * c), p.W.coeff(3 * c + 1, 3 * c + 1),
                                 p.W.coeff(3 * c + 2, 3 * c + 2)});
      rho_[c] = 1.0 / d;
      trace += p.W.coeff(3 * c, 3 * c) + p.W.coeff(3 * c + 1, 3 * c + 1) + p.W.coeff(3 * c + 2, 3 * c + 2);
    }
    mean_diag_ = trace / m;
  }

  double MeanDiagonal() const { return mean_diag_; }

  /// u = W r + q (the original problem's velocities).
  const Eigen::VectorXd& Velocity(const Eigen::VectorXd& r) {
    la_.Multiply(r, &u_);
    u_ += p_.q;
    return u_;
  }

  /// phi_sigma at r (proximal centre `centre`), and when `jacobian`, its blocks.
  void Evaluate(const Eigen::VectorXd& r, const Eigen::VectorXd& centre, double sigma, Eigen::VectorXd* phi,
                bool jacobian) {
    Velocity(r);
    u_ += sigma * (r - centre);
    for (int c = 0; c < p_.contacts; ++c) {
      Mat3 A, B;
      phi->segment<3>(3 * c) = Local(c, r.segment<3>(3 * c), u_.segment<3>(3 * c), jacobian ? &A : nullptr, &B);
      if (!jacobian) continue;
      B_[c] = B;
      D_[c] = A + sigma * B;
    }
  }

  /// Factorises J for the last Evaluate with a Jacobian; false when that fails.
  bool Factorize() { return la_.Factorize(B_, D_); }
  void Solve(const Eigen::VectorXd& rhs, Eigen::VectorXd* x) { la_.Solve(rhs, x); }

 private:
  Vec3 Local(int c, const Vec3& r, const Vec3& u, Mat3* A, Mat3* B) const {
    const double rho = rho_[c], mu = p_.mu[c];
    const double zn = r[0] - rho * u[0];
    const bool active = zn > 0.0;
    const double radius = mu * std::max(0.0, zn);
    const Eigen::Vector2d rt = r.tail<2>(), zt = rt - rho * u.tail<2>();
    const double nz = zt.norm();
    Vec3 f;
    f[0] = active ? rho * u[0] : r[0];
    Mat3 a = Mat3::Zero(), b = Mat3::Zero();
    if (active) b(0, 0) = rho;
    else a(0, 0) = 1.0;
    if (!(radius > 0.0)) {  // no friction available: r_T = 0
      f.tail<2>() = rt;
      a.bottomRightCorner<2, 2>().setIdentity();
    } else if (nz <= radius) {  // stick
      f.tail<2>() = rt - zt;
      b.bottomRightCorner<2, 2>() = rho * Eigen::Matrix2d::Identity();
    } else {  // slide: r_T - radius zt / |zt|
      const Eigen::Vector2d zh = zt / nz;
      const Eigen::Matrix2d Q = (radius / nz) * (Eigen::Matrix2d::Identity() - zh * zh.transpose());
      f.tail<2>() = rt - radius * zh;
      a.bottomRightCorner<2, 2>() = Eigen::Matrix2d::Identity() - Q;
      a.block<2, 1>(1, 0) = -mu * zh;
      b.bottomRightCorner<2, 2>() = rho * Q;
      b.block<2, 1>(1, 0) = mu * rho * zh;
    }
    if (A) *A = a;
    *B = b;
    return f;
  }

  const FcProblem& p_;
  LinearAlgebra la_;
  std::vector<double> rho_;
  std::vector<Mat3> B_, D_;
  double mean_diag_ = 1.0;
  Eigen::VectorXd u_;
};

double SiconosErrorOf(const FcProblem& p, const Eigen::VectorXd& r, const Eigen::VectorXd& u) {
  double num = 0.0;
  for (int c = 0; c < p.contacts; ++c)
    num += LocalErrorSquared(r.segment<3>(3 * c), u.segment<3>(3 * c), p.mu[c]);
  const double den = std::max({p.q.norm(), r.norm(), u.norm()});
  return den > 2.220446049250313e-16 ? std::sqrt(num) / den : std::sqrt(num);
}

// The race of FcNewtonParams::rival_rate: true when, past its grace, Newton's
// error has fallen more slowly per second (of its own steps) than the rival's would
bool Outpaced(const FcNewtonParams& params, int steps, double start_error, double best_error, double spent) {
  if (!(params.rival_rate < 0.0) || steps < params.rival_after) return false;
  if (spent < params.rival_grace_s || !(spent > 0.0) || !(start_error > 0.0)) return false;
  return std::log(best_error / start_error) / spent > params.rival_rate;
}

// the line search's memory and the watchdog (see fc_newton.h)
constexpr int kNonmonotone = 10;
constexpr int kWatchdog = 10;

}  // namespace

struct FcNewtonRun::State {
  explicit State(const FcProblem& p) : ac(p) {}
  AlartCurnier ac;
  Eigen::VectorXd r, phi, trial_phi, d, trial, centre;
  std::vector<double> merits;  ///< the last kNonmonotone merits |phi(r)|, oldest first
  double sigma_min = 0.0, sigma_max = 0.0, force_limit = 0.0;
};

FcNewtonRun::FcNewtonRun(const FcProblem& p, const FcNewtonParams& params, const Eigen::VectorXd& r0)
    : p_(p), params_(params), s_(std::make_unique<State>(p)) {
  const int m = 3 * p.contacts;
  State& s = *s_;
  s.r = r0.size() == m ? r0 : Eigen::VectorXd::Zero(m);
  s.phi.resize(m);
  s.trial_phi.resize(m);
  s.d.resize(m);
  s.trial.resize(m);
  s.centre = s.r;
  const double diag = s.ac.MeanDiagonal();
  s.sigma_min = 1e-12 * diag;
  s.sigma_max = 1e8 * diag;
  // forces beyond this are taken as divergence: far above any force that balances q
  s.force_limit = 1e12 * std::max(1.0, p.q.norm() / diag);
  sigma_ = params.sigma0 * diag;
  best_ = s.r;
  res_.error = start_error_ = SiconosErrorOf(p, s.r, s.ac.Velocity(s.r));
  res_.stop = EFcStop::IterationCap;
  if (res_.error <= params.tolerance) Finish(EFcStop::Converged);
}

FcNewtonRun::~FcNewtonRun() = default;

bool FcNewtonRun::Finish(EFcStop stop) {
  ended_ = true;
  res_.stop = res_.error <= params_.tolerance ? EFcStop::Converged : stop;
  res_.converged = res_.stop == EFcStop::Converged;
  res_.sigma = sigma_;
  return false;
}

bool FcNewtonRun::Step() {
  if (ended_) return false;
  if (res_.factorizations >= params_.max_iterations) return Finish(EFcStop::IterationCap);
  if (params_.time_budget_s > 0.0 && seconds_ > params_.time_budget_s) return Finish(EFcStop::TimeCap);
  const auto t0 = std::chrono::steady_clock::now();
  const bool going = Iterate();
  seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (going && Outpaced(params_, res_.iterations, start_error_, res_.error, seconds_)) return Finish(EFcStop::Outpaced);
  return going;
}

// the watchdog: back to the best forces, the line search monotone for a while
void FcNewtonRun::Restart() {
  s_->r = best_;
  s_->merits.clear();
  since_best_ = 0;
  monotone_left_ = kNonmonotone;
}

// the step length: halved from 1 until the proximal merit at r + t d falls below
// the reference; false when no length of 30 halvings does
bool FcNewtonRun::LineSearch(double reference, double* t) {
  State& s = *s_;
  *t = 1.0;
  for (int k = 0; k < 30 && s.d.allFinite(); ++k, *t *= 0.5) {
    s.trial = s.r + *t * s.d;
    s.ac.Evaluate(s.trial, s.centre, sigma_, &s.trial_phi, false);
    if (s.trial_phi.norm() <= (1.0 - 1e-4 * *t) * reference) return true;
  }
  return false;
}

bool FcNewtonRun::Iterate() {
  State& s = *s_;
  if (since_best_ >= kWatchdog) Restart();
  s.centre = s.r;
  s.ac.Evaluate(s.r, s.centre, sigma_, &s.phi, true);
  ++res_.factorizations;
  if (!s.ac.Factorize()) {
    sigma_ = std::min(s.sigma_max, 10.0 * sigma_);
    return true;
  }
  s.ac.Solve(-s.phi, &s.d);
  const double merit = s.phi.norm();
  if (monotone_left_ > 0) --monotone_left_;
  if (static_cast<int>(s.merits.size()) == kNonmonotone) s.merits.erase(s.merits.begin());
  s.merits.push_back(merit);
  const double reference = monotone_left_ > 0 ? merit : *std::max_element(s.merits.begin(), s.merits.end());
  double t = 1.0;
  if (!LineSearch(reference, &t)) {
    if (sigma_ >= s.sigma_max) return Finish(EFcStop::LineSearchFailed);
    sigma_ = std::min(s.sigma_max, 10.0 * sigma_);
    return true;
  }
  ++res_.iterations;
  s.r = s.trial;
  sigma_ = t == 1.0 ? std::max(s.sigma_min, 0.25 * sigma_) : std::min(s.sigma_max, 2.0 * sigma_);
  const double e = SiconosErrorOf(p_, s.r, s.ac.Velocity(s.r));
  ++since_best_;
  if (e < res_.error) {
    res_.error = e;
    best_ = s.r;
    since_best_ = 0;
  }
  if (res_.error <= params_.tolerance) return Finish(EFcStop::Converged);
  if (!(s.r.norm() < s.force_limit)) return Finish(EFcStop::Diverged);
  return true;
}

FcNewtonResult SolveFcNewton(const FcProblem& p, const FcNewtonParams& params, Eigen::VectorXd* r) {
  FcNewtonRun run(p, params, *r);
  while (run.Step()) {
  }
  *r = run.Best();
  return run.Result();
}

}  // namespace gs
