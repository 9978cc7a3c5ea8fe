#include "core/fc_problem.h"

#include <chrono>
#include <cmath>
#include <random>

namespace gs {

const char* CheckFcProblem(const FcProblem& p) {
  const int m = 3 * p.contacts;
  if (p.contacts <= 0) return "no contacts";
  if (p.W.rows() != m || p.W.cols() != m) return "W is not 3n x 3n for n contacts";
  if (p.q.size() != m) return "q does not have 3n entries";
  if (p.mu.size() != p.contacts) return "mu does not have one entry per contact";
  if (!p.q.allFinite()) return "q holds NaN or Inf";
  if (!p.mu.allFinite() || p.mu.minCoeff() < 0.0) return "mu holds a negative, NaN or Inf coefficient";
  for (int k = 0; k < p.W.outerSize(); ++k)
    for (SparseRowMatrix::InnerIterator it(p.W, k); it; ++it)
      if (!std::isfinite(it.value())) return "W holds NaN or Inf";
  for (int c = 0; c < p.contacts; ++c)
    if (!(p.W.coeff(3 * c, 3 * c) > 0.0)) return "a diagonal entry W_NN is not positive";
  return "";
}

SparseDelassus::SparseDelassus(const FcProblem& p) : p_(p), diag_(p.contacts), row_start_(p.contacts + 1, 0) {
  std::vector<int> slot(p.contacts, -1);
  for (int c = 0; c < p.contacts; ++c) {
    const int first = static_cast<int>(col_.size());
    row_start_[c] = first;
    for (int k = 0; k < 3; ++k)
      for (SparseRowMatrix::InnerIterator it(p.W, 3 * c + k); it; ++it) {
        const int j = it.index() / 3;
        if (slot[j] < first) {
          slot[j] = static_cast<int>(col_.size());
          col_.push_back(j);
          blocks_.resize(blocks_.size() + 9, 0.0);
        }
        blocks_[9 * static_cast<size_t>(slot[j]) + 3 * (it.index() - 3 * j) + k] = it.value();
      }
    Mat3 d = Mat3::Zero();
    for (int k = first; k < static_cast<int>(col_.size()); ++k)
      if (col_[k] == c) d = Eigen::Map<const Mat3>(blocks_.data() + 9 * static_cast<size_t>(k));
    diag_[c] = d;
  }
  row_start_[p.contacts] = static_cast<int>(col_.size());
}

double FcError(const FcProblem& p, const Eigen::VectorXd& r) {
  SparseDelassus op(p);
  return SiconosError(op, reinterpret_cast<const Vec3*>(r.data()));
}

double FcScaledError(const FcProblem& p, const Eigen::VectorXd& r, double gap_scale) {
  SparseDelassus op(p);
  NsgsParams np;
  np.measure = EStopMeasure::Scaled;
  np.gap_scale = gap_scale;
  return ExactErrors(op, reinterpret_cast<const Vec3*>(r.data()), np).stop;
}

FcSolveResult SolveFcProblem(const FcProblem& p, const FcSolveParams& params, Eigen::VectorXd* r) {
  FcSolveResult out;
  const auto t0 = std::chrono::steady_clock::now();
  if (r->size() != 3 * p.contacts) r->setZero(3 * p.contacts);
  SparseDelassus op(p);
  NsgsScratch scratch;
  Vec3* rv = reinterpret_cast<Vec3*>(r->data());
  out.nsgs = SolveNsgs(op, rv, params.nsgs, scratch);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

FcProblem RandomRigidProblem(int contacts, int layers, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0), mu_dist(0.1, 1.0);
  const int boxes = std::max(1, (contacts + 3) / 4);
  layers = std::max(1, layers);
  const double h = 0.1, mass = 1.0, dt = 1e-2, g = 9.81;
  const double inertia = mass * (2 * h * h) / 12.0;
  // per box: centre, linear and angular free velocity
  std::vector<Vec3> centre(boxes), v(boxes), w(boxes);
  const int stacks = (boxes + layers - 1) / layers;
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(stacks))));
  for (int b = 0; b < boxes; ++b) {
    const int stack = b / layers, level = b % layers;
    centre[b] = Vec3(1.5 * h * (stack % side), 1.5 * h * (stack / side), h * (level + 0.5));
    v[b] = Vec3(0.05 * uni(rng), 0.05 * uni(rng), -g * dt + 0.02 * uni(rng));
    w[b] = Vec3(0.3 * uni(rng), 0.3 * uni(rng), 0.3 * uni(rng));
  }
  FcProblem p;
  p.contacts = 4 * boxes;
  const int m = 3 * p.contacts;
  // H: one 3x6 block per contact side, u = H_upper v_upper - H_lower v_lower
  struct Side {
    int body;
    Eigen::Matrix<double, 3, 6> h;
  };
  std::vector<std::vector<Side>> rows(p.contacts);
  p.q.setZero(m);
  p.mu.resize(p.contacts);
  for (int b = 0; b < boxes; ++b) {
    const int level = b % layers;
    for (int k = 0; k < 4; ++k) {
      const int c = 4 * b + k;
      const Vec3 corner = centre[b] + Vec3(((k & 1) ? 0.5 : -0.5) * h, ((k & 2) ? 0.5 : -0.5) * h, -0.5 * h);
      Vec3 n = Vec3(0.05 * uni(rng), 0.05 * uni(rng), 1.0).normalized();
      const Vec3 t1 = AnyPerpendicular(n), t2 = n.cross(t1);
      Mat3 frame;
      frame.row(0) = n;
      frame.row(1) = t1;
      frame.row(2) = t2;
      auto block = [&](int body, double sign) {
        Eigen::Matrix<double, 3, 6> J;
        J.leftCols<3>().setIdentity();
        J.rightCols<3>() = -Skew(corner - centre[body]);
        return Side{body, sign * frame * J};
      };
      rows[c].push_back(block(b, 1.0));
      if (level > 0) rows[c].push_back(block(b - 1, -1.0));
      Vec3 u = Vec3::Zero();
      for (const Side& s : rows[c]) {
        Vec6 vb;
        vb << v[s.body], w[s.body];
        u += s.h * vb;
      }
      p.q.segment<3>(3 * c) = u;
      p.mu[c] = mu_dist(rng);
    }
  }
  // W = H M^-1 H^T: contacts sharing a body couple
  std::vector<std::vector<int>> by_body(boxes);
  for (int c = 0; c < p.contacts; ++c)
    for (const Side& s : rows[c]) by_body[s.body].push_back(c);
  Vec6 minv;
  minv << Vec3::Constant(1.0 / mass), Vec3::Constant(1.0 / inertia);
  std::vector<Eigen::Triplet<double>> trip;
  for (int c = 0; c < p.contacts; ++c) {
    for (const Side& s : rows[c]) {
      for (int d : by_body[s.body]) {
        for (const Side& sd : rows[d]) {
          if (sd.body != s.body) continue;
          const Mat3 blk = s.h * minv.asDiagonal() * sd.h.transpose();
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) trip.emplace_back(3 * c + i, 3 * d + j, blk(i, j));
        }
      }
    }
  }
  p.W.resize(m, m);
  p.W.setFromTriplets(trip.begin(), trip.end());
  p.W.makeCompressed();
  return p;
}

}  // namespace gs
