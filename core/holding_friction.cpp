#include "core/holding_friction.h"

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <vector>

namespace gs {
namespace {

// One pushing contact on the body: where its forces act, its normal force on the
// body and the tangent plane's basis.
struct Push {
  Vec3 x, n, t1, t2;
  Vec3 spin = Vec3::Zero();    ///< the normal force's torque per newton beyond x's (where the surfaces touch)
  double N = 0.0;
  Vec3 t_step = Vec3::Zero();  ///< the step's tangential force on the body
};

std::vector<Push> Pushes(const World& w, int body) {
  std::vector<Push> out;
  const Body& b = w.bodies[body];
  // a free body's rows say where their forces act on it (ContactSide::lever, spin):
  // at the material point (a deformable body's anchor displaced by u), the normal
  // force about where the rest surfaces touch; other bodies' rows at the contact point
  const bool free = b.articulation >= 0 && w.articulations[b.articulation].finger < 0;
  for (const ContactRow& r : w.rows) {
    // the row's force frame^T r acts on body[0]; body[1] gets its opposite
    const int k = r.contact.body[0] == body ? 0 : (r.contact.body[1] == body ? 1 : -1);
    if (k < 0 || !(r.r.x() > 0.0)) continue;
    const double s = k == 0 ? 1.0 : -1.0;
    Push p;
    p.x = free ? Vec3(b.pose.t + r.side[k].lever) : r.world_point;
    if (free) p.spin = s * r.side[k].spin;
    p.n = s * r.frame.row(0).transpose();
    p.t1 = r.frame.row(1).transpose();
    p.t2 = r.frame.row(2).transpose();
    p.N = r.r.x();
    p.t_step = s * (r.r.y() * p.t1 + r.r.z() * p.t2);
    out.push_back(p);
  }
  return out;
}

// Equilibrium of the tangential forces t (two per contact, in its basis):
// A t = b, with b what the weight and the normal forces leave (force, torque about c).
void Equilibrium(const std::vector<Push>& ps, const Vec3& c, const Vec3& weight, Eigen::MatrixXd* A,
                 Eigen::VectorXd* b) {
  const int k = static_cast<int>(ps.size());
  A->resize(6, 2 * k);
  Vec3 F = weight, M = Vec3::Zero();
  for (int i = 0; i < k; ++i) {
    const Push& p = ps[i];
    F += p.N * p.n;
    M += (p.x - c).cross(p.N * p.n) + p.N * p.spin;
    A->block<3, 1>(0, 2 * i) = p.t1;
    A->block<3, 1>(0, 2 * i + 1) = p.t2;
    A->block<3, 1>(3, 2 * i) = (p.x - c).cross(p.t1);
    A->block<3, 1>(3, 2 * i + 1) = (p.x - c).cross(p.t2);
  }
  b->resize(6);
  b->head<3>() = -F;
  b->tail<3>() = -M;
}

// The barrier problem: minimise tau mu - sum log(mu^2 N_c^2 - |t_c|^2) over
// (y, mu), with t = t0 + Z y; +inf outside the cones.
struct Barrier {
  const std::vector<Push>& ps;
  const Eigen::VectorXd& t0;
  const Eigen::MatrixXd& Z;

  double Value(const Eigen::VectorXd& v, double tau) const {
    const int d = static_cast<int>(Z.cols());
    const double mu = v[d];
    const Eigen::VectorXd t = t0 + Z * v.head(d);
    double f = tau * mu;
    for (size_t i = 0; i < ps.size(); ++i) {
      const double s = mu * mu * ps[i].N * ps[i].N - t.segment<2>(2 * i).squaredNorm();
      if (!(s > 0.0) || !(mu > 0.0)) return std::numeric_limits<double>::infinity();
      f -= std::log(s);
    }
    return f;
  }

  // gradient g and Hessian H of Value at v
  void Derivatives(const Eigen::VectorXd& v, double tau, Eigen::VectorXd* g, Eigen::MatrixXd* H) const {
    const int d = static_cast<int>(Z.cols());
    const double mu = v[d];
    const Eigen::VectorXd t = t0 + Z * v.head(d);
    g->setZero(d + 1);
    H->setZero(d + 1, d + 1);
    (*g)[d] = tau;
    Eigen::VectorXd ds(d + 1);
    for (size_t i = 0; i < ps.size(); ++i) {
      const Eigen::MatrixXd Zc = Z.middleRows(2 * i, 2);
      const Eigen::Vector2d tc = t.segment<2>(2 * i);
      const double N2 = ps[i].N * ps[i].N;
      const double s = mu * mu * N2 - tc.squaredNorm();
      ds.head(d) = -2.0 * Zc.transpose() * tc;
      ds[d] = 2.0 * mu * N2;
      *g -= ds / s;
      *H += ds * ds.transpose() / (s * s);
      H->topLeftCorner(d, d) += 2.0 * Zc.transpose() * Zc / s;
      (*H)(d, d) -= 2.0 * N2 / s;
    }
  }

  // Newton's method with backtracking on the barrier at tau, from v (feasible)
  void Centre(Eigen::VectorXd* v, double tau) const {
    Eigen::VectorXd g;
    Eigen::MatrixXd H;
    for (int it = 0; it < 100; ++it) {
      Derivatives(*v, tau, &g, &H);
      const Eigen::VectorXd step = -H.ldlt().solve(g);
      const double decrement = -g.dot(step);
      if (!(decrement > 1e-14)) return;
      const double f0 = Value(*v, tau);
      double a = 1.0;
      while (a > 1e-12 && !(Value(*v + a * step, tau) <= f0 - 0.25 * a * decrement)) a *= 0.5;
      if (a <= 1e-12) return;
      *v += a * step;
    }
  }
};

}  // namespace

HoldingFriction LeastHoldingFriction(const World& w, int body) {
  HoldingFriction out;
  const Body& b = w.bodies[body];
  const std::vector<Push> ps = Pushes(w, body);
  const int k = static_cast<int>(ps.size());
  out.contacts = k;
  Eigen::MatrixXd A;
  Eigen::VectorXd rhs;
  Equilibrium(ps, b.pose.t, b.mass * w.params.gravity, &A, &rhs);
  Eigen::VectorXd t_step(2 * k);
  for (int i = 0; i < k; ++i) t_step.segment<2>(2 * i) << ps[i].t_step.dot(ps[i].t1), ps[i].t_step.dot(ps[i].t2);
  const Eigen::VectorXd net = A * t_step - rhs;
  out.net_force = net.head<3>().norm();
  out.net_torque = net.tail<3>().norm();
  out.mu = std::numeric_limits<double>::infinity();
  if (k == 0) return out;
  // tangential forces that cannot balance the load at all: no friction holds the body
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const int rank = static_cast<int>(svd.rank());
  const Eigen::VectorXd t0 = svd.solve(rhs);
  // (a load the tangential forces cannot reach, say along the normals of a flat pinch,
  // must already balance: to 1e-6 of the forces involved)
  double scale = b.mass * w.params.gravity.norm();
  for (const Push& p : ps) scale += p.N;
  out.unreached = (A * t0 - rhs).norm();
  if (out.unreached > 1e-6 * scale) return out;
  const Eigen::MatrixXd Z = svd.matrixV().rightCols(2 * k - rank);
  const Barrier barrier{ps, t0, Z};
  // start inside every cone: the least-norm distribution, mu above its largest ratio
  const int d = static_cast<int>(Z.cols());
  Eigen::VectorXd v = Eigen::VectorXd::Zero(d + 1);
  for (int i = 0; i < k; ++i) v[d] = std::max(v[d], t0.segment<2>(2 * i).norm() / ps[i].N);
  v[d] = 1.5 * v[d] + 1e-6;
  // the central path: the barrier's gap to the optimum is k / tau
  for (double tau = 1.0 / v[d]; k / tau > 1e-9 * v[d]; tau *= 4.0) barrier.Centre(&v, tau);
  out.mu = v[d];
  return out;
}

}  // namespace gs
