// What the solver reads of a contact side (a free body's lever arm, from which
// core/contact_jacobian.h applies H and A^-1 H^T in place, and a deformable
// side's sign * frame * R, applied at the solve) must describe the same
// Delassus operator as the contact space's own diagonal blocks: assembled
// column by column through the solver's operator, W must be symmetric and its
// diagonal blocks must equal w_diag. A wrong sign, a missing transpose or a
// stale rotation breaks one of the two; the levers' rows are also checked
// against the explicit H = sign * frame * [I, -[lever]x].
#include <gtest/gtest.h>

#include "core/contact_jacobian.h"
#include "core/world.h"
#include "operator_check.h"
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
        // a free body's rows, applied in place from the lever arm, against the explicit
        // H = sign * frame * [I, -[lever]x] and A^-1 H^T
        ASSERT_LT(s.jacobian, 0);
        Eigen::Matrix<double, 3, 6> J;
        J << Mat3::Identity(), -Skew(s.lever);
        Eigen::Matrix<double, 3, 6> H = s.sign * row.frame * J;
        H.row(0).tail<3>() += s.sign * s.spin.transpose();  // the normal row's arm ends at the touching point
        // the lever reaches the contact point (from the centre at the solve; the step moved it since)
        EXPECT_LT((s.lever - (row.world_point - b.pose.t)).norm(), 1e-3);
        // probed through the accumulators of w itself, restored after
        std::vector<Vec6> saved;
        for (const Articulation& x : w.articulations) saved.push_back(x.dq);
        World& probe = w;
        Articulation& a = probe.articulations[s.articulation];
        ContactRow alone = row;
        alone.side[1 - (&s - row.side)].articulation = -1;  // this side only
        for (int k = 0; k < 6; ++k) {
          for (Articulation& x : probe.articulations) x.dq.setZero();
          a.dq[k] = 1.0;
          EXPECT_LE((ArticulatedVelocity(probe, alone) - H.col(k)).norm(), 1e-12 * H.norm()) << "dof " << k;
          EXPECT_NEAR(ArticulatedNormalVelocity(probe, alone), H(0, k), 1e-12 * H.norm()) << "dof " << k;
        }
        const Eigen::Matrix<double, 6, 3> G = a.a_inv * H.transpose();
        for (int k = 0; k < 3; ++k) {
          a.dq.setZero();
          ApplyArticulatedDelta(probe, alone, Vec3::Unit(k));
          EXPECT_LE((a.dq - G.col(k)).norm(), 1e-12 * G.norm()) << "force row " << k;
        }
        a.dq.setZero();
        ApplyArticulatedNormalDelta(probe, alone, 1.0);
        EXPECT_LE((a.dq - G.col(0)).norm(), 1e-12 * G.norm());
        for (size_t i = 0; i < saved.size(); ++i) probe.articulations[i].dq = saved[i];
        ++articulated;
      }
      if (s.count > 0 || s.inf_count > 0) ++deformable;
    }
  }
  EXPECT_GT(articulated, 0);
  EXPECT_GT(deformable, static_cast<int>(w.rows.size()));  // both sides of most contacts
  // W through the solver's operator (levers, rotations at the solve, merged influences)
  // against w_diag
  test::ExpectOperatorMatchesContactSpace(w);
}

}  // namespace
}  // namespace gs
