// `graspsim solve FILE --write-solution OUT`: the solution written is checked
// outside graspsim. OUT is read back with libfclib's own readers, and Siconos'
// error measure (fc3d_compute_error, as /work/shared/SOLVER-REFERENCE.md defines
// it) is recomputed here from its definition, sharing no code with graspsim's
// solver or error (core/local_solver.cpp).
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "fclib/fclib_io.h"
#include "core/fc_families.h"

#ifdef GRASPSIM_HAVE_FCLIB
extern "C" {
#include <fclib.h>
}
#endif

namespace gs::app {
namespace {

const std::string kData = GRASPSIM_TEST_DATA;

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("graspsim_solcheck_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

#ifdef GRASPSIM_HAVE_FCLIB

// projection onto {|x_T| <= mu x_N}, written from the definition
void ProjectCone(const double x[3], double mu, double out[3]) {
  const double xt = std::hypot(x[1], x[2]);
  if (mu * xt <= -x[0]) {
    out[0] = out[1] = out[2] = 0.0;
  } else if (xt <= mu * x[0]) {
    for (int k = 0; k < 3; ++k) out[k] = x[k];
  } else {
    const double n = (mu * xt + x[0]) / (1.0 + mu * mu);
    out[0] = n;
    out[1] = mu * n * x[1] / xt;
    out[2] = mu * n * x[2] / xt;
  }
}

struct Checked {
  double error = NAN;
  double stored_u_gap = NAN;  // |u stored - (W r + q)| / max(1, |u|)
};

// Siconos' fc3d error of the solution stored in `path`, from libfclib's readers.
Checked IndependentError(const std::string& path) {
  Checked out;
  fclib_local* lp = fclib_read_local(path.c_str());
  fclib_solution* sol = fclib_read_solution(path.c_str());
  if (!lp || !sol || !sol->r || !sol->u || lp->W->nz != -1) return out;  // graspsim writes W compressed-column
  const fclib_matrix& W = *lp->W;
  const int m = W.m, n = m / 3;
  std::vector<double> u(lp->q, lp->q + m);
  for (int col = 0; col < W.n; ++col)
    for (int k = W.p[col]; k < W.p[col + 1]; ++k) u[W.i[k]] += W.x[k] * sol->r[col];
  double num = 0.0, nr = 0.0, nu = 0.0, nq = 0.0, du = 0.0;
  for (int c = 0; c < n; ++c) {
    const double* r = sol->r + 3 * c;
    const double* v = u.data() + 3 * c;
    const double mu = lp->mu[c];
    const double x[3] = {r[0] - (v[0] + mu * std::hypot(v[1], v[2])), r[1] - v[1], r[2] - v[2]};
    double p[3];
    ProjectCone(x, mu, p);
    for (int k = 0; k < 3; ++k) {
      num += (r[k] - p[k]) * (r[k] - p[k]);
      nr += r[k] * r[k];
      nu += v[k] * v[k];
      nq += lp->q[3 * c + k] * lp->q[3 * c + k];
      du += (sol->u[3 * c + k] - v[k]) * (sol->u[3 * c + k] - v[k]);
    }
  }
  const double den = std::sqrt(std::max({nq, nr, nu}));
  out.error = den > DBL_EPSILON ? std::sqrt(num) / den : std::sqrt(num);
  out.stored_u_gap = std::sqrt(du) / std::max(1.0, std::sqrt(nu));
  fclib_delete_solutions(sol, 1);
  fclib_delete_local(lp);
  return out;
}

int Solve(const std::string& in, const std::string& out, const std::string& extra) {
  const std::string cmd = std::string(GRASPSIM_BINARY) + " solve " + in + " --write-solution " + out + " " + extra +
                          " > " + out + ".txt";
  return WEXITSTATUS(std::system(cmd.c_str()));
}

TEST(SolutionCheck, AStackNsgsCannotFinishSolvedByAutoPassesAnIndependentSiconosMeasure) {
  const std::string in = TempPath("stack.hdf5"), out = TempPath("stack_solution.hdf5");
  std::string error;
  ASSERT_TRUE(WriteFclibLocal(in, MassRatioStackProblem(4, 1000.0, 1), "stack", "test", nullptr, &error)) << error;
  ASSERT_EQ(Solve(in, out, "--solver auto --tolerance 1e-6"), 0);
  const Checked c = IndependentError(out);
  EXPECT_LE(c.error, 1e-6);
  EXPECT_LE(c.stored_u_gap, 1e-12);  // the stored u is W r + q of the stored r
  // the same file solved by NSGS alone under a sweep cap does not pass
  ASSERT_EQ(Solve(in, out, "--solver nsgs --max-iterations 5000"), 1);
  EXPECT_GT(IndependentError(out).error, 1e-6);
  for (const std::string& f : {in, out, out + ".txt"}) std::remove(f.c_str());
}

TEST(SolutionCheck, AGrippedBodySolvedByNewtonPassesAnIndependentSiconosMeasure) {
  const std::string in = TempPath("gripped.hdf5"), out = TempPath("gripped_solution.hdf5");
  std::string error;
  ASSERT_TRUE(WriteFclibLocal(in, GrippedBodyProblem(24, 1), "gripped", "test", nullptr, &error)) << error;
  ASSERT_EQ(Solve(in, out, "--solver newton"), 0);
  const Checked c = IndependentError(out);
  EXPECT_LE(c.error, 1e-6);
  EXPECT_GT(c.error, 0.0);
  for (const std::string& f : {in, out, out + ".txt"}) std::remove(f.c_str());
}

TEST(SolutionCheck, TheRealSamplesPassAnIndependentSiconosMeasure) {
  for (const std::string name : {"Capsules-i125-1213.hdf5", "LMGC_100_PR_PerioBox-i00361-60-03000.hdf5"}) {
    const std::string out = TempPath("sample_solution.hdf5");
    ASSERT_EQ(Solve(kData + "/fclib/" + name, out, "--tolerance 1e-6"), 0) << name;
    const Checked c = IndependentError(out);
    EXPECT_LE(c.error, 1e-6) << name;
    EXPECT_GT(c.error, 0.0) << name;  // a real, non-trivial check
    for (const std::string& f : {out, out + ".txt"}) std::remove(f.c_str());
  }
}

TEST(SolutionCheck, RefusesToOverwriteItsInput) {
  const std::string in = TempPath("self.hdf5");
  std::string error;
  ASSERT_TRUE(WriteFclibLocal(in, ConeProblem(1.0, 1), "cone", "test", nullptr, &error)) << error;
  const std::string cmd = std::string(GRASPSIM_BINARY) + " solve " + in + " --write-solution " + in + " 2> " + in +
                          ".err > /dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 2);  // refused before the solve, as a bad command line
  std::ifstream err(in + ".err");
  std::string line;
  std::getline(err, line);
  EXPECT_NE(line.find("is the input file"), std::string::npos) << line;
  FcProblem p;
  EXPECT_TRUE(ReadFclibLocal(in, &p, &error)) << error;  // untouched
  for (const std::string& f : {in, in + ".err"}) std::remove(f.c_str());
}

TEST(SolutionCheck, AFolderThatIsNotThereIsRefusedBeforeTheSolve) {
  const std::string in = TempPath("nofolder.hdf5");
  std::string error;
  ASSERT_TRUE(WriteFclibLocal(in, ConeProblem(1.0, 1), "cone", "test", nullptr, &error)) << error;
  const std::string cmd = std::string(GRASPSIM_BINARY) + " solve " + in + " --write-solution " + in +
                          ".d/no/such/out.hdf5 > " + in + ".out 2>&1";
  EXPECT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 2);
  std::ifstream f(in + ".out");
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("--write-solution " + in + ".d/no/such/out.hdf5"), std::string::npos) << text;
  EXPECT_EQ(text.find("contacts"), std::string::npos) << "the problem was solved first\n" << text;
  for (const std::string& f2 : {in, in + ".out"}) std::remove(f2.c_str());
}

#endif

}  // namespace
}  // namespace gs::app
