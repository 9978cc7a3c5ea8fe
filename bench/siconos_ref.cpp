#include "bench/siconos_ref.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#ifdef GRASPSIM_HAVE_SICONOS
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <FrictionContactProblem.h>
#include <Friction_cst.h>
#include <NonSmoothDrivers.h>
#include <NumericsMatrix.h>
#include <NumericsVerbose.h>
#include <SolverOptions.h>
#include <SparseBlockMatrix.h>
#include <fc3d_compute_error.h>
#endif

namespace gs::app {

const char* SiconosSolverName(ESiconosSolver solver) {
  switch (solver) {
    case ESiconosSolver::Nsgs:
      return "NSGS";
    case ESiconosSolver::NsnAc:
      return "NSN_AC";
    case ESiconosSolver::Prox:
      return "PROX";
  }
  return "?";
}

#ifndef GRASPSIM_HAVE_SICONOS

bool SiconosAvailable() { return false; }
SiconosRun SolveWithSiconos(const FcProblem&, ESiconosSolver, double, int, Eigen::VectorXd*) { return {}; }
SiconosRun SolveWithSiconosIsolated(const FcProblem&, ESiconosSolver, double, int, Eigen::VectorXd*) { return {}; }

#else

namespace {

// Siconos writes diagnostics on stdout: point fd 1 at /dev/null while it runs.
class QuietStdout {
 public:
  QuietStdout() {
    std::fflush(stdout);
    saved_ = dup(1);
    const int null = open("/dev/null", O_WRONLY);
    if (null >= 0) {
      dup2(null, 1);
      close(null);
    }
  }
  ~QuietStdout() {
    std::fflush(stdout);
    if (saved_ >= 0) {
      dup2(saved_, 1);
      close(saved_);
    }
  }
  QuietStdout(const QuietStdout&) = delete;
  QuietStdout& operator=(const QuietStdout&) = delete;

 private:
  int saved_ = -1;
};

// W as a Siconos sparse-block matrix of 3x3 blocks (what NSGS and PROX read fastest).
NumericsMatrix* ToNumerics(const FcProblem& p) {
  const int m = 3 * p.contacts;
  NumericsMatrix* t = NM_create(NM_SPARSE, m, m);
  NM_triplet_alloc(t, static_cast<CS_INT>(p.W.nonZeros()));
  for (int row = 0; row < p.W.outerSize(); ++row)
    for (SparseRowMatrix::InnerIterator it(p.W, row); it; ++it) NM_zentry(t, row, it.index(), it.value(), 0.0);
  SparseBlockStructuredMatrix* sbm = SBM_new();
  const int rc = SBM_from_csparse(3, NM_csc(t), sbm);
  NM_clear(t);
  std::free(t);
  if (rc != 0) {
    SBM_clear(sbm);
    std::free(sbm);
    return nullptr;
  }
  return NM_new_SBM(m, m, sbm);
}

int SiconosId(ESiconosSolver solver) {
  switch (solver) {
    case ESiconosSolver::Nsgs:
      return SICONOS_FRICTION_3D_NSGS;
    case ESiconosSolver::NsnAc:
      return SICONOS_FRICTION_3D_NSN_AC;
    case ESiconosSolver::Prox:
      return SICONOS_FRICTION_3D_PROX;
  }
  return SICONOS_FRICTION_3D_NSGS;
}

// The fixed-size part of a SiconosRun as the child sends it, then 3n doubles of forces.
struct RunHeader {
  int info, iterations;
  double seconds, error;
};

bool WriteAll(int fd, const void* data, size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t k = write(fd, p, n);
    if (k <= 0) return false;
    p += k, n -= static_cast<size_t>(k);
  }
  return true;
}

bool ReadAll(int fd, void* data, size_t n) {
  char* p = static_cast<char*>(data);
  while (n > 0) {
    const ssize_t k = read(fd, p, n);
    if (k <= 0) return false;
    p += k, n -= static_cast<size_t>(k);
  }
  return true;
}

[[noreturn]] void ChildSolve(int fd, const FcProblem& p, ESiconosSolver solver, double tolerance, int max_iterations) {
  Eigen::VectorXd r;
  const SiconosRun run = SolveWithSiconos(p, solver, tolerance, max_iterations, &r);
  const RunHeader h{run.info, run.iterations, run.seconds, run.error};
  const bool ok = WriteAll(fd, &h, sizeof h) && r.size() == 3 * p.contacts &&
                  WriteAll(fd, r.data(), sizeof(double) * static_cast<size_t>(r.size()));
  _exit(ok ? 0 : 1);
}

}  // namespace

bool SiconosAvailable() { return true; }

SiconosRun SolveWithSiconos(const FcProblem& p, ESiconosSolver solver, double tolerance, int max_iterations,
                            Eigen::VectorXd* r_out) {
  SiconosRun run;
  run.available = true;
  run.tolerance = tolerance;
  const int m = 3 * p.contacts;
  NumericsMatrix* W = ToNumerics(p);
  if (!W) return run;
  // the problem takes ownership of W, q and mu (malloc'd)
  double* q = static_cast<double*>(std::malloc(sizeof(double) * m));
  double* mu = static_cast<double*>(std::malloc(sizeof(double) * p.contacts));
  std::memcpy(q, p.q.data(), sizeof(double) * m);
  std::memcpy(mu, p.mu.data(), sizeof(double) * p.contacts);
  FrictionContactProblem* fc = frictionContactProblem_new_with_data(3, p.contacts, W, q, mu);
  SolverOptions* o = solver_options_create(SiconosId(solver));
  o->dparam[SICONOS_DPARAM_TOL] = tolerance;
  o->iparam[SICONOS_IPARAM_MAX_ITER] = max_iterations;
  std::vector<double> r(m, 0.0), u(m, 0.0);
  {
    QuietStdout quiet;
    numerics_set_verbose(0);
    const auto t0 = std::chrono::steady_clock::now();
    run.info = fc3d_driver(fc, r.data(), u.data(), o);
    run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    run.iterations = o->iparam[SICONOS_IPARAM_ITER_DONE];
    double err = NAN;
    fc3d_compute_error(fc, r.data(), u.data(), tolerance, o, p.q.norm(), &err);
    run.error = err;
  }
  if (r_out) *r_out = Eigen::Map<const Eigen::VectorXd>(r.data(), m);
  solver_options_delete(o);
  frictionContactProblem_free(fc);
  return run;
}

SiconosRun SolveWithSiconosIsolated(const FcProblem& p, ESiconosSolver solver, double tolerance, int max_iterations,
                                    Eigen::VectorXd* r_out) {
  SiconosRun run;
  run.available = true;
  run.tolerance = tolerance;
  int fds[2];
  if (pipe(fds) != 0) return run;
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return run;
  }
  if (pid == 0) {
    close(fds[0]);
    ChildSolve(fds[1], p, solver, tolerance, max_iterations);
  }
  close(fds[1]);
  RunHeader h{};
  Eigen::VectorXd r(3 * p.contacts);
  const bool got = ReadAll(fds[0], &h, sizeof h) && ReadAll(fds[0], r.data(), sizeof(double) * r.size());
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (WIFSIGNALED(status)) run.signal = WTERMSIG(status);
  if (!got || run.signal != 0) return run;
  run.info = h.info;
  run.iterations = h.iterations;
  run.seconds = h.seconds;
  run.error = h.error;
  if (r_out) *r_out = r;
  return run;
}

#endif

}  // namespace gs::app
