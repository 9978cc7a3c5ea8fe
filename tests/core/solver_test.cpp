#include <gtest/gtest.h>

#include <random>

#include "core/fc_problem.h"
#include "core/local_solver.h"

namespace gs {
namespace {

// a random symmetric positive definite 3x3 block, optionally made non-symmetric
Mat3 RandomBlock(std::mt19937_64& rng, double skew) {
  std::uniform_real_distribution<double> u(-1, 1);
  Mat3 A;
  for (int i = 0; i < 9; ++i) A(i / 3, i % 3) = u(rng);
  Mat3 W = A * A.transpose() + 0.2 * Mat3::Identity();
  Mat3 S;
  for (int i = 0; i < 9; ++i) S(i / 3, i % 3) = u(rng);
  return W + skew * (S - S.transpose());
}

TEST(LocalSolver, SolvesEveryCaseExactlyIncludingNonSymmetricBlocks) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1), mu_dist(0.05, 1.5);
  int counts[4] = {0, 0, 0, 0};
  for (int trial = 0; trial < 3000; ++trial) {
    const Mat3 W = RandomBlock(rng, trial % 3 == 0 ? 0.05 : 0.0);
    const Vec3 q(u(rng), u(rng), u(rng));
    const double mu = mu_dist(rng);
    Vec3 r;
    const ELocalCase c = SolveLocalCoulomb(W, q, mu, &r);
    ++counts[static_cast<int>(c)];
    const Vec3 v = W * r + q;
    ASSERT_LT(std::sqrt(LocalErrorSquared(r, v, mu)), 1e-9 * (1 + r.norm() + v.norm()))
        << "trial " << trial << " case " << static_cast<int>(c);
  }
  // every case was met
  EXPECT_GT(counts[0], 100);
  EXPECT_GT(counts[1], 100);
  EXPECT_GT(counts[2], 100);
}

TEST(LocalSolver, ErrorMeasureIsZeroOnlyAtASolution) {
  const double mu = 0.5;
  // sliding: r on the cone boundary, u_t opposed to r_t, u_n = 0
  EXPECT_LT(LocalErrorSquared(Vec3(1, -0.5, 0), Vec3(0, 2, 0), mu), 1e-30);
  // same but u_t along r_t: not a solution
  EXPECT_GT(LocalErrorSquared(Vec3(1, 0.5, 0), Vec3(0, 2, 0), mu), 1e-3);
  // separated: r = 0 and u_n > 0
  EXPECT_LT(LocalErrorSquared(Vec3::Zero(), Vec3(1, 3, -2), mu), 1e-30);
  // force while separating: not a solution
  EXPECT_GT(LocalErrorSquared(Vec3(1, 0, 0), Vec3(1, 0, 0), mu), 1e-3);
}

TEST(Nsgs, ConvergesOnRandomRigidProblemsAndReportsTheTrueError) {
  for (int contacts : {50, 200}) {
    const FcProblem p = RandomRigidProblem(contacts, 3, 11);
    ASSERT_EQ(std::string(CheckFcProblem(p)), "");
    FcSolveParams sp;
    sp.nsgs.tolerance = 1e-6;
    sp.nsgs.max_iterations = 5000;
    Eigen::VectorXd r;
    const FcSolveResult res = SolveFcProblem(p, sp, &r);
    EXPECT_TRUE(res.nsgs.converged) << contacts;
    EXPECT_NEAR(res.nsgs.error, FcError(p, r), 1e-15);
    EXPECT_LE(FcError(p, r), 1e-6);
    // a wrong answer has a large error: the measure is not trivially small
    Eigen::VectorXd wrong = r;
    wrong *= 1.5;
    EXPECT_GT(FcError(p, wrong), 1e-3);
  }
}

TEST(Nsgs, IterationCapIsReportedNotHidden) {
  const FcProblem p = RandomRigidProblem(400, 4, 3);
  FcSolveParams sp;
  sp.nsgs.tolerance = 1e-12;
  sp.nsgs.max_iterations = 3;
  Eigen::VectorXd r;
  const FcSolveResult res = SolveFcProblem(p, sp, &r);
  EXPECT_FALSE(res.nsgs.converged);
  EXPECT_EQ(res.nsgs.iterations, 3);
  EXPECT_GT(res.nsgs.error, 1e-12);
  EXPECT_NEAR(res.nsgs.error, FcError(p, r), 1e-15);
}

TEST(FcProblem, CheckRefusesIllPosedProblems) {
  FcProblem p = RandomRigidProblem(8, 1, 1);
  EXPECT_EQ(std::string(CheckFcProblem(p)), "");
  FcProblem bad = p;
  bad.mu[0] = -0.1;
  EXPECT_NE(std::string(CheckFcProblem(bad)), "");
  bad = p;
  bad.q[2] = NAN;
  EXPECT_NE(std::string(CheckFcProblem(bad)), "");
  bad = p;
  bad.mu.resize(3);
  EXPECT_NE(std::string(CheckFcProblem(bad)), "");
}

}  // namespace
}  // namespace gs
