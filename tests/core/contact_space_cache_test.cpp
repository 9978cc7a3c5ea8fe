// The per-side products the solver reads (ContactSide::g = A^-1 h^T and
// ContactSide::m = sign * frame * R, set by BuildContactSpace so that a
// Gauss-Seidel update costs fewer multiplications) must describe the same
// Delassus operator as the contact space's own diagonal blocks: assembled
// column by column through the solver's operator, W must be symmetric and its
// diagonal blocks must equal w_diag. A wrong sign, a missing transpose or a
// stale rotation in g or m breaks one of the two.
#include <gtest/gtest.h>

#include "core/world.h"
#include "soft_bodies.h"

namespace gs {
namespace {

// a deformable ball (free) pressed on a deformable fixed slab: both sides of every
// contact deformable, one articulated
void BallOnSlab(World& w) {
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-8;
  w.params.solver.max_iterations = 500;
  ASSERT_GE(AddBody(w, test::SoftSlab("slab")), 0);
  BodySpec ball = test::SoftBall();
  // turned, so that R is not the identity and a missing rotation shows
  ball.pose.R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  ball.pose.t = Vec3(0, 0, 0.0199);
  ASSERT_GE(AddBody(w, ball), 0);
  w.Finalize();
}

TEST(ContactSpaceCache, OperatorMatchesDiagonalBlocksAndIsSymmetric) {
  World w;
  BallOnSlab(w);
  for (int i = 0; i < 20; ++i) w.Step();
  ASSERT_GE(w.rows.size(), 3u);
  // the cached products themselves
  int articulated = 0, deformable = 0;
  for (const ContactRow& row : w.rows) {
    for (const ContactSide& s : row.side) {
      const Body& b = w.bodies[s.body];
      if (s.articulation >= 0) {
        const Eigen::Matrix<double, 6, 3> g = w.articulations[s.articulation].a_inv * s.h.transpose();
        EXPECT_LE((s.g - g).norm(), 1e-12 * g.norm());
        ++articulated;
      }
      if (s.count > 0 || s.inf_count > 0) {
        // sign * frame * R at the solve (the step has moved the pose since): a rotation,
        // up to the sign, whose transpose takes the frame's normal to the rest frame
        EXPECT_LE((s.m * s.m.transpose() - Mat3::Identity()).norm(), 1e-12);
        EXPECT_LT((s.m.row(0).transpose() - s.sign * b.pose.R.transpose() * row.frame.row(0).transpose()).norm(), 0.05);
        ++deformable;
      }
    }
  }
  EXPECT_GT(articulated, 0);
  EXPECT_GT(deformable, static_cast<int>(w.rows.size()));  // both sides of most contacts
  // W through the solver's operator (it reads g and m) against w_diag (built from h, A^-1
  // and the W_deform terms, without m)
  FcProblem p;
  AssembleContactProblem(w, &p);
  const Eigen::MatrixXd W(p.W);
  const double scale = W.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0);
  EXPECT_LE((W - W.transpose()).cwiseAbs().maxCoeff(), 1e-9 * scale);
  for (size_t c = 0; c < w.rows.size(); ++c) {
    const Mat3 block = W.block<3, 3>(3 * c, 3 * c);
    EXPECT_LE((block - w.rows[c].w_diag).cwiseAbs().maxCoeff(), 1e-9 * scale) << "contact " << c;
  }
}

}  // namespace
}  // namespace gs
