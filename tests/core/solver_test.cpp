#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "core/world.h"
#include "core/fc_families.h"
#include "core/fc_problem.h"
#include "core/local_solver.h"
#include "core/nsgs.h"

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

// Conjugate directions (NsgsParams::conjugate, on for explicit problems) on top of
// the extrapolation reach the same tolerance in fewer sweeps on hyperstatic
// problems, and the forces they return solve the problem by the exact measure.
// Measured (sweeps, extrapolation alone -> with conjugate directions): random_rigid
// 150 1,839 -> 1,053, pile_12 1,886 -> 914, stack_4_ratio10 2,226 -> 445,
// gripped_48 624 -> 81.
// Conjugate directions that stop paying are dropped: on a pile of 400 boxes (1,617
// contacts) they took the estimate to 7e-5, then cycled at 1e-4..7e-4 to the
// 20,000-sweep cap (error 3.1e-4); plain sweeps from there converge
// The step's Newton continuation is bounded by a fixed amount of work, the same on
// every machine: every step it may take up to about 100 contacts, fewer above, none
// from 382 on (a 951-contact replay step had taken 4-5 s of dense factorisations)
TEST(Newton, TheStepsContinuationIsBoundedByWork) {
  WorldParams wp;
  EXPECT_EQ(NewtonStepsAllowed(wp, 0), 0);
  EXPECT_EQ(NewtonStepsAllowed(wp, 8), wp.newton_max_steps);
  EXPECT_EQ(NewtonStepsAllowed(wp, 100), wp.newton_max_steps);
  EXPECT_EQ(NewtonStepsAllowed(wp, 150), 16);
  EXPECT_EQ(NewtonStepsAllowed(wp, 300), 2);
  EXPECT_EQ(NewtonStepsAllowed(wp, 381), 1);
  EXPECT_EQ(NewtonStepsAllowed(wp, 382), 0);
  EXPECT_EQ(NewtonStepsAllowed(wp, 951), 0);
  wp.newton_max_steps = 0;  // off
  EXPECT_EQ(NewtonStepsAllowed(wp, 8), 0);
}

TEST(Nsgs, MomentumThatStopsPayingIsDropped) {
  const FcProblem p = PileProblem(400, 0.3, 1.0, 1);
  FcSolveParams sp;
  ASSERT_TRUE(sp.nsgs.conjugate);
  sp.nsgs.tolerance = 1e-6;
  sp.nsgs.max_iterations = 20000;
  Eigen::VectorXd r;
  const FcSolveResult res = SolveFcProblem(p, sp, &r);
  // converged before the cap (release: 3,884 sweeps; the sanitizer build's rounding
  // takes another path through the pile, 15,565)
  EXPECT_TRUE(res.nsgs.converged) << res.nsgs.error;
  EXPECT_LE(FcError(p, r), 1e-6);
  EXPECT_LT(res.nsgs.iterations, 20000);
}

TEST(Nsgs, ConjugateDirectionsNeedFewerSweepsForTheSameError) {
  int without = 0, with = 0;
  for (const FcProblem& p : {RandomRigidProblem(150, 3, 1), PileProblem(12, 0.3, 1.0, 1),
                             MassRatioStackProblem(4, 10, 1), GrippedBodyProblem(48, 1)}) {
    FcSolveParams plain, conj;
    plain.nsgs.conjugate = false;
    ASSERT_TRUE(conj.nsgs.conjugate);
    for (FcSolveParams* sp : {&plain, &conj}) {
      sp->nsgs.tolerance = 1e-6;
      sp->nsgs.max_iterations = 20000;
    }
    Eigen::VectorXd r_plain, r_conj;
    const FcSolveResult a = SolveFcProblem(p, plain, &r_plain);
    const FcSolveResult b = SolveFcProblem(p, conj, &r_conj);
    ASSERT_TRUE(a.nsgs.converged);
    ASSERT_TRUE(b.nsgs.converged);
    EXPECT_LE(FcError(p, r_conj), 1e-6);
    EXPECT_NEAR(b.nsgs.error, FcError(p, r_conj), 1e-15);
    for (int c = 0; c < p.contacts; ++c)  // the momentum's forces are projected on their cones
      EXPECT_LE(std::hypot(r_conj[3 * c + 1], r_conj[3 * c + 2]), p.mu[c] * r_conj[3 * c] * (1 + 1e-12) + 1e-300);
    EXPECT_LT(b.nsgs.iterations, a.nsgs.iterations) << a.nsgs.iterations << " " << b.nsgs.iterations;
    without += a.nsgs.iterations;
    with += b.nsgs.iterations;
  }
  EXPECT_LT(with, 0.6 * without) << without << " " << with;
}

// A rigid object (0.15 kg) pressed onto a soft skin (300 N/m) through side x side
// contacts 2 mm apart, the skin's control points 3 mm apart under a Gaussian of
// width sigma: a contact moves its neighbours by most of what it moves itself, as
// the whole hand's phalanges on the paper's box do (there W's normal part has a
// condition number of 1.4e5). Each W block is (K_ij + dt^2 / m) I in gap units
// (m/N); the object's free motion closes the gaps by 10 um and more in the step
// and, with `slide`, drags them sideways, so that some contacts stick and some slide
// at mu = 0.5.
FcProblem DenseSkinPatch(int side = 7, double sigma = 3e-3, double slide = 1e-3) {
  const double h = 2e-3, spacing = 3e-3, k = 300.0, rigid = 1e-6 / 0.15;
  std::vector<Eigen::Vector2d> at, ctrl;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j) at.emplace_back(i * h, j * h);
  for (double x = -2 * spacing; x <= (side - 1) * h + 2 * spacing; x += spacing)
    for (double y = -2 * spacing; y <= (side - 1) * h + 2 * spacing; y += spacing) ctrl.emplace_back(x, y);
  const int n = static_cast<int>(at.size());
  Eigen::MatrixXd phi(ctrl.size(), n);
  for (size_t m = 0; m < ctrl.size(); ++m)
    for (int c = 0; c < n; ++c) phi(m, c) = std::exp(-(at[c] - ctrl[m]).squaredNorm() / (sigma * sigma));
  const Eigen::MatrixXd K = phi.transpose() * phi / k;
  FcProblem p;
  p.contacts = n;
  p.mu = Eigen::VectorXd::Constant(n, 0.5);
  p.q.resize(3 * n);
  std::vector<Eigen::Triplet<double>> t;
  for (int a = 0; a < n; ++a) {
    const Eigen::Vector2d d = at[a] - Eigen::Vector2d(3 * h, 3 * h);
    p.q.segment<3>(3 * a) = Vec3(-1e-5 - 5e-4 * d.squaredNorm() / h, slide * (4e-3 + d.x()), slide * d.y());
    for (int b = 0; b < n; ++b)
      for (int i = 0; i < 3; ++i) t.emplace_back(3 * a + i, 3 * b + i, K(a, b) + rigid);
  }
  p.W.resize(3 * n, 3 * n);
  p.W.setFromTriplets(t.begin(), t.end());
  return p;
}

// Anderson acceleration (NsgsParams::anderson_depth, on in the step) reaches the
// step's tolerance on the scaled measure in fewer sweeps than plain Gauss-Seidel on
// dense contacts under a wide skin, and the forces it returns solve the problem by
// the exact measure. Over the whole family: 3,586 sweeps plain against 1,683; one
// member needs about as many either way (494 and 507).
TEST(Nsgs, AndersonAccelerationSolvesDenseSkinContactsInFewerSweeps) {
  const double gap_scale = 9.81e-6, tolerance = 1e-4;
  int total[2] = {0, 0};
  for (int side : {10, 14})
    for (double sigma : {3e-3, 4e-3})
      for (double slide : {1e-3, 1e-4, 0.0}) {
        const FcProblem p = DenseSkinPatch(side, sigma, slide);
        ASSERT_EQ(std::string(CheckFcProblem(p)), "");
        int sweeps[2] = {0, 0};
        for (int depth : {0, kStepAndersonDepth}) {
          NsgsParams np;
          np.measure = EStopMeasure::Scaled;
          np.gap_scale = gap_scale;
          np.tolerance = tolerance;
          np.max_iterations = 20000;
          np.anderson_depth = depth;
          SparseDelassus op(p);
          NsgsScratch scratch;
          std::vector<Vec3> r(p.contacts, Vec3::Zero());
          const NsgsResult res = SolveNsgs(op, r.data(), np, scratch);
          const std::string what = "side " + std::to_string(side) + " sigma " + std::to_string(sigma) + " slide " +
                                   std::to_string(slide) + " depth " + std::to_string(depth);
          ASSERT_TRUE(res.converged) << what << ": error " << res.error;
          Eigen::VectorXd x(3 * p.contacts);
          for (int c = 0; c < p.contacts; ++c) x.segment<3>(3 * c) = r[c];
          EXPECT_LE(FcScaledError(p, x, gap_scale), tolerance) << what;
          // the object is held: a good part of the contacts press (the skin lifts
          // some off), and the measure is not trivially small for other forces
          int pressing = 0;
          for (int c = 0; c < p.contacts; ++c) pressing += r[c][0] > 0.0;
          EXPECT_GE(pressing, side) << what;
          EXPECT_GT(FcScaledError(p, 1.1 * x, gap_scale), 10 * tolerance) << what;
          sweeps[depth > 0] = res.iterations;
        }
        // never far worse than plain sweeps (the watch turns a combination that
        // stopped paying off)
        EXPECT_LT(sweeps[1], sweeps[0] + 2 * kAndersonWindow) << side << " " << sigma << " " << slide;
        total[0] += sweeps[0];
        total[1] += sweeps[1];
      }
  std::printf("dense skin patches: %d sweeps plain, %d with Anderson acceleration\n", total[0], total[1]);
  EXPECT_LT(total[1], 0.6 * total[0]);
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

TEST(Nsgs, TimeBudgetStopsSweepingAndReportsTheExactErrorReached) {
  const FcProblem p = RandomRigidProblem(400, 4, 3);
  FcSolveParams sp;
  sp.nsgs.tolerance = 1e-10;
  sp.nsgs.max_iterations = 5000;
  Eigen::VectorXd r_free, r_budget, r_roomy;
  const FcSolveResult free = SolveFcProblem(p, sp, &r_free);
  ASSERT_GT(free.nsgs.iterations, 3);
  // a budget already spent after the first sweep: one sweep, then the exact error of what it left
  sp.nsgs.time_budget_s = 1e-9;
  const FcSolveResult cut = SolveFcProblem(p, sp, &r_budget);
  EXPECT_EQ(cut.nsgs.iterations, 1);
  EXPECT_FALSE(cut.nsgs.converged);
  EXPECT_TRUE(cut.nsgs.budget_stopped);
  EXPECT_NEAR(cut.nsgs.error, FcError(p, r_budget), 1e-15);
  EXPECT_GT(cut.nsgs.error, free.nsgs.error);
  // a budget far beyond what the solve needs changes nothing
  sp.nsgs.time_budget_s = 100.0;
  const FcSolveResult roomy = SolveFcProblem(p, sp, &r_roomy);
  EXPECT_FALSE(roomy.nsgs.budget_stopped);
  EXPECT_EQ(roomy.nsgs.iterations, free.nsgs.iterations);
  EXPECT_EQ((r_roomy - r_free).norm(), 0.0);
}

// The budget's two rules: another sweep plus the exact pass (Exhausted), the exact
// pass alone (HoldsErrorPass); no budget holds everything.
TEST(Nsgs, BudgetRulesCountSweepsAndTheErrorPass) {
  const NsgsBudget none(0.0);
  EXPECT_FALSE(none.Exhausted(1));
  EXPECT_TRUE(none.HoldsErrorPass(1));
  const NsgsBudget roomy(100.0);
  EXPECT_FALSE(roomy.Exhausted(1));
  EXPECT_TRUE(roomy.HoldsErrorPass(1));
  const NsgsBudget spent(1e-12);  // over once any time has passed
  volatile double sink = 0.0;
  for (int i = 0; i < 1000; ++i) sink = sink + std::sqrt(static_cast<double>(i));
  EXPECT_TRUE(spent.Exhausted(1));
  EXPECT_FALSE(spent.HoldsErrorPass(1));
  EXPECT_TRUE(spent.HoldsErrorPass(0));  // no sweep yet: nothing to measure the pass by
}

// Warm started at or near a solution, a sweep barely moves the forces: the bound of
// the error is accepted without the exact pass, and it bounds the exact error. Far
// from converged the bound is not accepted and the exact pass decides.
TEST(Nsgs, AcceptedErrorBoundHoldsTheExactError) {
  for (int contacts : {50, 200}) {
    const FcProblem p = RandomRigidProblem(contacts, 3, 5);
    FcSolveParams sp;
    sp.nsgs.tolerance = 1e-12;  // far below the tolerance below: a sweep then barely moves r
    sp.nsgs.max_iterations = 50000;
    Eigen::VectorXd r;
    ASSERT_TRUE(SolveFcProblem(p, sp, &r).nsgs.converged);
    sp.nsgs.tolerance = 1e-6;
    sp.nsgs.accept_error_bound = true;
    for (double nudge : {0.0, 1e-9, 1e-7}) {
      Eigen::VectorXd start = r;
      for (int i = 0; i < start.size(); ++i) start[i] += nudge * ((i % 7) - 3);
      const FcSolveResult res = SolveFcProblem(p, sp, &start);
      ASSERT_TRUE(res.nsgs.converged) << contacts << " " << nudge;
      const double exact = FcError(p, start);
      EXPECT_LE(exact, res.nsgs.error * (1.0 + 1e-12)) << contacts << " " << nudge;
      EXPECT_LE(res.nsgs.error, sp.nsgs.tolerance);
      if (nudge == 0.0) {
        EXPECT_TRUE(res.nsgs.error_bounded) << contacts;
        EXPECT_EQ(res.nsgs.exact_checks, 0);
        EXPECT_EQ(res.nsgs.iterations, 1);
      }
      if (!res.nsgs.error_bounded) {
        EXPECT_NEAR(res.nsgs.error, exact, 1e-15);
      }
    }
    // from zero forces the first sweeps change everything: no bound is accepted there
    Eigen::VectorXd zero;
    const FcSolveResult cold = SolveFcProblem(p, sp, &zero);
    EXPECT_TRUE(cold.nsgs.converged);
    EXPECT_GT(cold.nsgs.iterations, 1);
    EXPECT_LE(FcError(p, zero), cold.nsgs.error * (1.0 + 1e-12));
  }
}

TEST(LocalSolver, SlideFromAnAngleHintIsAsExactAsFromNone) {
  // the slide case first tries Newton on the slip angle from the hint; a hint
  // far from the root must still end in an exact solution (the scan takes over)
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(-1, 1), mu_dist(0.05, 1.5);
  int slides = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Mat3 W = RandomBlock(rng, trial % 2 ? 0.05 : 0.0);
    const Vec3 q(u(rng), u(rng), u(rng));
    const double mu = mu_dist(rng);
    Vec3 r0;
    double angle = NAN;
    if (SolveLocalCoulomb(W, q, mu, &r0, &angle) != ELocalCase::Slide) continue;
    ++slides;
    for (const double offset : {1e-6, 0.3, 2.5}) {
      double hint = angle + offset;
      Vec3 r;
      ASSERT_EQ(SolveLocalCoulomb(W, q, mu, &r, &hint), ELocalCase::Slide);
      const Vec3 v = W * r + q;
      ASSERT_LT(std::sqrt(LocalErrorSquared(r, v, mu)), 1e-9 * (1 + r.norm() + v.norm())) << trial << " " << offset;
    }
  }
  EXPECT_GT(slides, 200);
}

TEST(SparseDelassus, BlockRowsReproduceTheSparseProduct) {
  // the block-CSR operator against Eigen's sparse product, on a W whose blocks
  // are partly filled (a block with one scalar entry must still be a block)
  FcProblem p = RandomRigidProblem(40, 3, 5);
  p.W.coeffRef(4, 20) = 0.25;  // contact 1 row, contact 6 column, lone entry
  p.W.makeCompressed();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::VectorXd r(3 * p.contacts);
  for (int i = 0; i < r.size(); ++i) r[i] = u(rng);
  const Eigen::VectorXd expect = p.W * r + p.q;
  SparseDelassus op(p);
  for (int c = 0; c < p.contacts; ++c) {
    const Vec3 got = op.Velocity(c, reinterpret_cast<const Vec3*>(r.data()));
    EXPECT_LT((got - expect.segment<3>(3 * c)).norm(), 1e-12) << c;
    Mat3 d;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) d(i, j) = p.W.coeff(3 * c + i, 3 * c + j);
    EXPECT_EQ(op.DiagonalBlock(c), d) << c;
  }
}

TEST(Nsgs, ExtrapolationConvergesWherePlainGaussSeidelDrifts) {
  // 500 contacts in 4-box stacks, 4 corner contacts per box: statically
  // indeterminate; plain NSGS is still above 1e-6 after 15,000 sweeps (it
  // drifts along the solution set with contacts flipping state), the
  // extrapolated one reaches it (about 12,000 sweeps)
  const FcProblem p = RandomRigidProblem(500, 4, 7);
  FcSolveParams sp;
  sp.nsgs.conjugate = false;  // extrapolation against plain Gauss-Seidel alone
  ASSERT_GT(sp.nsgs.extrapolate_every, 0);  // the default for explicit problems
  sp.nsgs.tolerance = 1e-6;
  sp.nsgs.max_iterations = 15000;
  Eigen::VectorXd r;
  const FcSolveResult res = SolveFcProblem(p, sp, &r);
  EXPECT_TRUE(res.nsgs.converged);
  EXPECT_LE(FcError(p, r), 1e-6);
  EXPECT_NEAR(res.nsgs.error, FcError(p, r), 1e-15);
  EXPECT_GT(res.nsgs.extrapolations, 0);
  EXPECT_LE(res.nsgs.iterations, 15000);
  // the forces are in their cones: extrapolated iterates are projected
  for (int c = 0; c < p.contacts; ++c)
    EXPECT_LE(std::hypot(r[3 * c + 1], r[3 * c + 2]), p.mu[c] * r[3 * c] * (1 + 1e-12) + 1e-300) << c;

  // plain Gauss-Seidel drifts: where it reaches the tolerance within the cap at all
  // (it does or does not by a hair, with the compiler's rounding), it takes more sweeps
  sp.nsgs.extrapolate_every = 0;
  Eigen::VectorXd r_plain;
  const FcSolveResult plain = SolveFcProblem(p, sp, &r_plain);
  std::printf("extrapolated: %d sweeps, error %.3g; plain: %d sweeps, error %.3g\n", res.nsgs.iterations,
              FcError(p, r), plain.nsgs.iterations, FcError(p, r_plain));
  EXPECT_GT(plain.nsgs.iterations, res.nsgs.iterations);
  if (!plain.nsgs.converged) {
    EXPECT_GT(FcError(p, r_plain), 1e-6);
  }
}

TEST(Nsgs, ExtrapolationReducesSweepsOnSmallStacks) {
  for (int contacts : {50, 150}) {
    const FcProblem p = RandomRigidProblem(contacts, 4, 7);
    FcSolveParams sp;
    sp.nsgs.conjugate = false;  // extrapolation against plain Gauss-Seidel alone
    sp.nsgs.max_iterations = 20000;
    Eigen::VectorXd r, r_plain;
    const FcSolveResult res = SolveFcProblem(p, sp, &r);
    sp.nsgs.extrapolate_every = 0;
    const FcSolveResult plain = SolveFcProblem(p, sp, &r_plain);
    ASSERT_TRUE(res.nsgs.converged && plain.nsgs.converged) << contacts;
    EXPECT_LT(res.nsgs.iterations, 0.9 * plain.nsgs.iterations) << contacts;
  }
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
