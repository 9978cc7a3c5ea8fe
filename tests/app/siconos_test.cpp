// Our error measure and problem hand-over against Siconos Numerics itself.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "app/siconos_ref.h"
#include "core/fc_problem.h"
#ifdef GRASPSIM_HAVE_FCLIB
#include "app/fclib_io.h"
#endif

namespace gs::app {
namespace {

// Siconos' fc3d_compute_error and our FcError are the same measure (SOLVER-REFERENCE):
// on forces Siconos computed, both must give the same number, and Siconos must see
// the same W, q and mu we built (otherwise its forces would not be a solution of ours).
void ExpectSameMeasure(const FcProblem& p, const char* what) {
  Eigen::VectorXd r;
  const SiconosRun run = SolveWithSiconos(p, ESiconosSolver::Nsgs, 1e-4, 5000, &r);
  ASSERT_EQ(r.size(), 3 * p.contacts) << what;
  ASSERT_TRUE(std::isfinite(run.error)) << what;
  EXPECT_GT(run.iterations, 0) << what;
  const double ours = FcError(p, r);
  EXPECT_NEAR(ours, run.error, 1e-9 + 1e-6 * run.error) << what;
  EXPECT_LT(ours, 1e-2) << what << ": Siconos' forces solve our problem";
  // and a perturbed force vector is measured alike
  Eigen::VectorXd bad = r;
  for (int i = 0; i < bad.size(); i += 7) bad[i] *= 1.5;
  EXPECT_GT(FcError(p, bad), ours) << what;
}

TEST(Siconos, SameErrorMeasureOnRandomRigidProblems) {
  // skipped only in builds without libsiconos-numerics-dev (optional; scripts/setup.sh installs it)
  if (!SiconosAvailable()) GTEST_SKIP() << "built without Siconos Numerics";
  ExpectSameMeasure(RandomRigidProblem(40, 2, 5), "random rigid 40");
  ExpectSameMeasure(RandomRigidProblem(120, 4, 9), "random rigid 120");
}

#ifdef GRASPSIM_HAVE_FCLIB
TEST(Siconos, SameErrorMeasureOnTheFclibSample) {
  // skipped only in builds without libsiconos-numerics-dev (optional; scripts/setup.sh installs it)
  if (!SiconosAvailable()) GTEST_SKIP() << "built without Siconos Numerics";
  FcProblem p;
  std::string error;
  ASSERT_TRUE(ReadFclibLocal(std::string(GRASPSIM_TEST_DATA) + "/fclib/LMGC_100_PR_PerioBox-i00361-60-03000.hdf5", &p,
                             &error))
      << error;
  ExpectSameMeasure(p, "PerioBox");
}
#endif

TEST(Siconos, BenchSolverQuickPrintsItsHeadlineAndSolvesEverything) {
#ifdef GRASPSIM_SANITIZED
  // skipped under sanitizers only (a benchmark run); the release suite runs it
  GTEST_SKIP() << "a benchmark run (about a minute under sanitizers); the release build runs it";
#endif
  const std::string out = std::string(::testing::TempDir()) + "/bench_solver.json";
  const std::string cmd = std::string(GRASPSIM_BINARY) + " bench solver --quick --json > " + out;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  FILE* f = std::fopen(out.c_str(), "r");
  ASSERT_NE(f, nullptr);
  std::string last, line;
  char buf[4096];
  int lines = 0;
  while (std::fgets(buf, sizeof buf, f)) {
    line = buf;
    if (!line.empty()) last = line, ++lines;
  }
  std::fclose(f);
  EXPECT_GE(lines, 4);  // one per problem, then the headline
  EXPECT_NE(last.find("\"bench\":\"solver\""), std::string::npos) << last;
  EXPECT_NE(last.find("\"worst_time_ratio_vs_nsgs\":"), std::string::npos) << last;
  EXPECT_NE(last.find("\"unsolved\":0}"), std::string::npos) << last;
}

}  // namespace
}  // namespace gs::app
