// The second method for what Gauss-Seidel cannot finish (core/fc_newton.h,
// core/fc_fallback.h) and the generators of hard problems (core/fc_families.h).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <string>

#include "core/fc_fallback.h"
#include "core/fc_families.h"

namespace gs {
namespace {

Eigen::MatrixXd Dense(const FcProblem& p) { return Eigen::MatrixXd(p.W); }

TEST(FcFamilies, GrippedBodyIsRankDeficientAsymmetricAndSpread) {
  const FcProblem p = GrippedBodyProblem(24, 3);
  ASSERT_EQ(std::string(CheckFcProblem(p)), "");
  EXPECT_EQ(p.contacts, 24);
  const Eigen::MatrixXd W = Dense(p);
  const Eigen::VectorXd s = W.jacobiSvd().singularValues();
  int rank = 0;
  for (int k = 0; k < s.size(); ++k) rank += s[k] > 1e-10 * s[0];
  EXPECT_LE(rank, 6);  // one rigid body: 72 rows, 6 degrees of freedom
  const double asym = (W - W.transpose()).norm() / W.norm();
  EXPECT_GT(asym, 1e-5);
  EXPECT_LT(asym, 1e-2);
  const Eigen::VectorXd d = W.diagonal();
  EXPECT_GT(d.maxCoeff() / d.minCoeff(), 20.0);
}

TEST(FcFamilies, DeterministicInTheSeedAndValid) {
  const FcProblem a = MassRatioStackProblem(4, 1000.0, 5), b = MassRatioStackProblem(4, 1000.0, 5),
                  c = MassRatioStackProblem(4, 1000.0, 6);
  EXPECT_EQ(Dense(a), Dense(b));
  EXPECT_EQ(a.q, b.q);
  EXPECT_NE(a.q, c.q);
  EXPECT_EQ(a.contacts, 16);
  for (const FcFamilyCase& k : FcFamilySuite(1, true)) EXPECT_EQ(std::string(CheckFcProblem(k.problem)), "") << k.name;
  const FcProblem cone = ConeProblem(10.0, 1);
  EXPECT_EQ(cone.mu.minCoeff(), 10.0);
  EXPECT_EQ(cone.mu.maxCoeff(), 10.0);
}

TEST(Fallback, NsgsStallsOnAHeavyOnLightStackAndAutoSolvesIt) {
  // 4 boxes, the top one 1000 times as heavy as the bottom one: NSGS (with its
  // extrapolation and conjugate directions) is at 1.1e-6 after 5,000 sweeps
  const FcProblem p = MassRatioStackProblem(4, 1000.0, 1);
  FcMethodParams mp;
  mp.max_sweeps = 5000;
  Eigen::VectorXd r_nsgs, r_auto;
  const FcMethodResult nsgs = SolveFcMethod(p, EFcMethod::Nsgs, mp, &r_nsgs);
  EXPECT_FALSE(nsgs.converged);
  EXPECT_EQ(nsgs.stop, EFcStop::IterationCap);
  EXPECT_EQ(nsgs.nsgs.iterations, 5000);
  EXPECT_GT(FcError(p, r_nsgs), 1e-6);
  const FcMethodResult aut = SolveFcMethod(p, EFcMethod::Auto, mp, &r_auto);
  EXPECT_TRUE(aut.converged) << aut.Summary();
  EXPECT_TRUE(aut.nsgs.stagnated);
  EXPECT_TRUE(aut.newton_ran);
  EXPECT_LE(FcError(p, r_auto), 1e-6);  // recomputed from the forces, on the original problem
  EXPECT_LT(aut.nsgs.iterations, 2000);
}

TEST(Fallback, NewtonAloneSolvesAGrippedBodyFromZeroForces) {
  const FcProblem p = GrippedBodyProblem(24, 1);
  FcMethodParams mp;
  Eigen::VectorXd r;
  const FcMethodResult res = SolveFcMethod(p, EFcMethod::Newton, mp, &r);
  EXPECT_TRUE(res.converged) << res.Summary();
  EXPECT_EQ(res.nsgs.iterations, 0);
  EXPECT_LE(FcError(p, r), 1e-6);
  // (release: under 50; the sanitizer build's rounding takes 64: the non-monotone
  // search's path depends on the last bits)
  EXPECT_LT(res.newton.factorizations, 100);
}

TEST(Fallback, AutoSolvesEveryGeneratedFamily) {
  for (const FcFamilyCase& k : FcFamilySuite(1, true)) {
    FcMethodParams mp;
    Eigen::VectorXd r;
    const FcMethodResult res = SolveFcMethod(k.problem, EFcMethod::Auto, mp, &r);
    EXPECT_TRUE(res.converged) << k.name << ": " << res.Summary();
    EXPECT_LE(FcError(k.problem, r), 1e-6) << k.name;
    EXPECT_TRUE(r.allFinite()) << k.name;
  }
}

// auto races Newton against the pace NSGS had when its stagnation rule fired; the
// race is on time, so which method finishes depends on the machine: both must end
// on a solution, and a Newton that lost hands over to NSGS, never stops the solve
TEST(Fallback, AutoEndsOnASolutionWhicheverMethodWinsTheRace) {
  // the pile trips the stagnation rule in the release build (600 sweeps) and, with
  // other rounding, may converge before it; the stack always stalls NSGS
  for (const bool stack : {false, true}) {
    const FcProblem p = stack ? MassRatioStackProblem(10, 1000.0, 1) : PileProblem(60, 0.1, 1.0, 1);
    FcMethodParams mp;
    mp.max_sweeps = 20000;
    Eigen::VectorXd r;
    const FcMethodResult res = SolveFcMethod(p, EFcMethod::Auto, mp, &r);
    EXPECT_TRUE(res.converged) << res.Summary();
    EXPECT_LE(FcError(p, r), 1e-6) << res.Summary();
    if (stack) {
      EXPECT_TRUE(res.newton_ran) << res.Summary();
    }
    if (res.nsgs_resumed) {
      // Newton lost the race, or won its second run after NSGS stalled again
      EXPECT_TRUE(res.newton.stop == EFcStop::Outpaced || res.newton_rerun) << res.Summary();
      EXPECT_NE(res.Summary().find("resumed after Newton"), std::string::npos);
    }
  }
}

TEST(Newton, ARivalFasterThanAnyNewtonStopsItAfterItsGraceWithItsBestForces) {
  const FcProblem p = MassRatioStackProblem(4, 1000.0, 1);
  FcNewtonParams np;
  np.rival_rate = -1e300;  // log(error) per second: no Newton keeps up
  np.rival_after = 3;
  Eigen::VectorXd r;
  const FcNewtonResult lost = SolveFcNewton(p, np, &r);
  EXPECT_EQ(lost.stop, EFcStop::Outpaced);
  EXPECT_EQ(lost.iterations, 3);
  EXPECT_FALSE(lost.converged);
  EXPECT_NEAR(FcError(p, r), lost.error, 1e-12);
  EXPECT_LT(lost.error, FcError(p, Eigen::VectorXd::Zero(3 * p.contacts)));
  np.rival_rate = -1e-300;  // a rival that barely moves: Newton goes on to the solution
  r.resize(0);
  const FcNewtonResult won = SolveFcNewton(p, np, &r);
  EXPECT_TRUE(won.converged) << FcStopName(won.stop);
  EXPECT_LE(FcError(p, r), 1e-6);
}

// The non-monotone line search: on a 10-box stack at mass ratio 100 (rank-deficient W,
// contacts with r_N = u_N = 0 at the solution) the monotone rule cut nearly every
// step short and took 157 steps from zero forces
TEST(Newton, ANonMonotoneLineSearchSolvesAStackInFewSteps) {
  const FcProblem p = MassRatioStackProblem(10, 100.0, 1);
  FcNewtonParams np;
  Eigen::VectorXd r;
  const FcNewtonResult res = SolveFcNewton(p, np, &r);
  EXPECT_TRUE(res.converged) << FcStopName(res.stop);
  EXPECT_LE(FcError(p, r), 1e-6);
  EXPECT_LT(res.iterations, 60);
}

// Runs stepped in turn keep nothing in common: each ends where it ends alone
TEST(Newton, InterleavedRunsEndAsTheyDoAlone) {
  const FcProblem p = MassRatioStackProblem(10, 10.0, 1);
  FcNewtonParams np;
  Eigen::VectorXd zero = Eigen::VectorXd::Zero(3 * p.contacts), nsgs;
  FcMethodParams mp;
  mp.max_sweeps = 300;
  SolveFcMethod(p, EFcMethod::Nsgs, mp, &nsgs);
  Eigen::VectorXd alone_a = zero, alone_b = nsgs;
  const FcNewtonResult ra = SolveFcNewton(p, np, &alone_a), rb = SolveFcNewton(p, np, &alone_b);
  FcNewtonRun a(p, np, zero), b(p, np, nsgs);
  while (!a.Ended() || !b.Ended()) {
    b.Step();
    a.Step();
  }
  EXPECT_EQ(a.Result().iterations, ra.iterations);
  EXPECT_EQ(b.Result().iterations, rb.iterations);
  EXPECT_EQ(a.Best(), alone_a);
  EXPECT_EQ(b.Best(), alone_b);
}

// auto's Newton stage runs from NSGS's stalled forces and from the start together:
// on the 10-box stack at mass ratio 100, Newton from NSGS's forces alone ended at its
// 200-step cap and auto took 17,876 sweeps
TEST(Fallback, AutoFinishesAStackThatNewtonFromTheStalledForcesCannot) {
  const FcProblem p = MassRatioStackProblem(10, 100.0, 1);
  FcMethodParams mp;
  Eigen::VectorXd r;
  const FcMethodResult res = SolveFcMethod(p, EFcMethod::Auto, mp, &r);
  EXPECT_TRUE(res.converged) << res.Summary();
  EXPECT_LE(FcError(p, r), 1e-6);
  EXPECT_TRUE(res.newton_ran) << res.Summary();
  EXPECT_FALSE(res.nsgs_resumed) << res.Summary();
  EXPECT_LT(res.nsgs.iterations, 2000) << res.Summary();
  EXPECT_LT(res.newton.factorizations, 120) << res.Summary();
}

// auto never ends short of where NSGS alone would go: a Newton stage that stops at
// its own cap hands the forces back to NSGS, which goes on without its rule
TEST(Fallback, AutoGoesOnWithNsgsWhenNewtonEndsAtItsCap) {
  const FcProblem p = RandomRigidProblem(150, 3, 1);
  FcMethodParams mp;
  mp.stagnation_window = 20;     // a rule that fires on any problem: 100x per 20 sweeps
  mp.stagnation_ratio = 0.01;
  mp.max_newton = 1;             // and a Newton stage that cannot finish
  Eigen::VectorXd r;
  const FcMethodResult res = SolveFcMethod(p, EFcMethod::Auto, mp, &r);
  EXPECT_TRUE(res.newton_ran) << res.Summary();
  EXPECT_TRUE(res.nsgs_resumed) << res.Summary();
  EXPECT_TRUE(res.converged) << res.Summary();
  EXPECT_LE(FcError(p, r), 1e-6) << res.Summary();
}

TEST(Fallback, EachCapSaysWhichCapEndedTheSolve) {
  const FcProblem p = GrippedBodyProblem(24, 2);
  FcMethodParams mp;
  Eigen::VectorXd r;
  mp.max_newton = 1;
  FcMethodResult res = SolveFcMethod(p, EFcMethod::Newton, mp, &r);
  EXPECT_FALSE(res.converged);
  EXPECT_EQ(res.stop, EFcStop::IterationCap);
  EXPECT_EQ(res.newton.factorizations, 1);
  EXPECT_NE(res.Summary().find("iteration cap reached"), std::string::npos) << res.Summary();

  mp = FcMethodParams();
  mp.max_sweeps = 50;
  r.resize(0);
  res = SolveFcMethod(MassRatioStackProblem(4, 1000.0, 1), EFcMethod::Nsgs, mp, &r);
  EXPECT_EQ(res.stop, EFcStop::IterationCap);
  EXPECT_EQ(res.nsgs.iterations, 50);

  mp = FcMethodParams();
  mp.time_budget_s = 1e-4;
  r.resize(0);
  res = SolveFcMethod(p, EFcMethod::Newton, mp, &r);
  EXPECT_EQ(res.stop, EFcStop::TimeCap) << res.Summary();
  EXPECT_NE(res.Summary().find("time budget reached"), std::string::npos);
}

// A body squeezed between two walls that both close in (q_N = -1 at both, opposite
// normals): u_N1 + u_N2 = -2 whatever the forces, so no solution exists.
FcProblem SqueezedBody() {
  FcProblem p;
  p.contacts = 2;
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(6, 6);
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d flip = Eigen::Vector3d(-1, 1, -1).asDiagonal();  // the second frame, turned over
  W.block<3, 3>(0, 0) = I;
  W.block<3, 3>(3, 3) = I;
  W.block<3, 3>(0, 3) = flip;
  W.block<3, 3>(3, 0) = flip;
  p.W = W.sparseView();
  p.q = Eigen::VectorXd::Zero(6);
  p.q[0] = p.q[3] = -1.0;
  p.mu = Eigen::Vector2d(0.5, 0.5);
  return p;
}

TEST(Fallback, AnInfeasibleProblemEndsWithAClearStatementNotAHang) {
  const FcProblem p = SqueezedBody();
  ASSERT_EQ(std::string(CheckFcProblem(p)), "");
  for (EFcMethod m : {EFcMethod::Nsgs, EFcMethod::Newton, EFcMethod::Auto}) {
    FcMethodParams mp;
    mp.max_sweeps = 2000;
    Eigen::VectorXd r;
    const FcMethodResult res = SolveFcMethod(p, m, mp, &r);
    EXPECT_FALSE(res.converged) << res.Summary();
    EXPECT_NE(res.stop, EFcStop::Converged);
    // (auto's Newton diverges unless, on a machine busy enough to stall it, it lost
    // its race to NSGS first: NSGS then runs to its cap, unconverged either way)
    if (m == EFcMethod::Newton || (m == EFcMethod::Auto && !res.nsgs_resumed)) {
      EXPECT_EQ(res.stop, EFcStop::Diverged) << res.Summary();
    }
    EXPECT_TRUE(std::isfinite(res.error)) << res.Summary();
    EXPECT_TRUE(r.allFinite()) << res.Summary();
    EXPECT_GT(res.error, 0.0) << res.Summary();
  }
}

}  // namespace
}  // namespace gs
