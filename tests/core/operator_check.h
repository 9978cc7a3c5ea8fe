// Shared check of the core tests: the Delassus operator the solver applies
// through the bodies, assembled column by column, is symmetric and its diagonal
// blocks are the contact space's W_cc (built separately, from J A^-1 J^T and the
// W_deform terms). A wrong sign or a missing transpose on either side breaks one.
#pragma once

#include <gtest/gtest.h>

#include "core/fc_problem.h"
#include "core/world.h"

namespace gs::test {

inline void ExpectOperatorMatchesContactSpace(World& w) {
  FcProblem p;
  AssembleContactProblem(w, &p);
  const Eigen::MatrixXd W(p.W);
  const double scale = W.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0);
  EXPECT_LE((W - W.transpose()).cwiseAbs().maxCoeff(), 1e-9 * scale);
  for (size_t c = 0; c < w.rows.size(); ++c)
    EXPECT_LE((W.block<3, 3>(3 * c, 3 * c) - w.rows[c].w_diag).cwiseAbs().maxCoeff(), 1e-9 * scale)
        << "contact " << c;
}

}  // namespace gs::test
