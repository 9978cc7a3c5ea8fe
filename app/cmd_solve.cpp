// `graspsim solve FILE.hdf5 [--json] [--tolerance X] [--max-iterations N]`:
// solves an FCLIB local frictional contact problem with our NSGS and prints the
// iterations, the Siconos error of the forces and the time.
#include <cstdio>
#include <memory>

#include "app/commands.h"
#include "app/fclib_io.h"

namespace gs::app {

struct SolveOptions {
  std::string file;
  bool json = false;
  double tolerance = 1e-6;
  int max_iterations = 100000;
  double over_relaxation = 1.0;
  std::string order = "forward";
  int extrapolate_every = FcSolveParams().nsgs.extrapolate_every;
};

int RunSolve(const SolveOptions& opt) {
  FcProblem p;
  std::string error;
  if (!ReadFclibLocal(opt.file, &p, &error)) {
    std::fprintf(stderr, "graspsim solve: %s\n", error.c_str());
    return kExitBadInput;
  }
  FcSolveParams params;
  params.nsgs.tolerance = opt.tolerance;
  params.nsgs.max_iterations = opt.max_iterations;
  params.nsgs.over_relaxation = opt.over_relaxation;
  params.nsgs.order = opt.order == "alternating" ? ESweepOrder::Alternating : ESweepOrder::Forward;
  params.nsgs.extrapolate_every = opt.extrapolate_every;
  Eigen::VectorXd r;
  const FcSolveResult res = SolveFcProblem(p, params, &r);
  const double error_check = FcError(p, r);
  if (opt.json) {
    std::printf("{\"file\":\"%s\",\"contacts\":%d,\"nnz\":%lld,\"tolerance\":%.3g,\"iterations\":%d,\"error\":%.6g,"
                "\"converged\":%s,\"time_ms\":%.6g,\"extrapolations\":%d}\n",
                opt.file.c_str(), p.contacts, static_cast<long long>(p.W.nonZeros()), opt.tolerance,
                res.nsgs.iterations, error_check, res.nsgs.converged ? "true" : "false", 1e3 * res.seconds,
                res.nsgs.extrapolations);
  } else {
    std::printf("%s: %d contacts, W %lld non-zeros\n", opt.file.c_str(), p.contacts,
                static_cast<long long>(p.W.nonZeros()));
    std::printf("NSGS (exact local Coulomb solve): %d iterations (%d extrapolations kept), error %.3e (Siconos "
                "measure), %.3f ms, %s\n",
                res.nsgs.iterations, res.nsgs.extrapolations, error_check, 1e3 * res.seconds,
                res.nsgs.converged ? "converged" : "NOT converged (iteration cap)");
  }
  return res.nsgs.converged ? kExitOk : kExitFailure;
}

void AddSolveCommand(CLI::App& app, int* exit_code) {
  auto opt = std::make_shared<SolveOptions>();
  CLI::App* cmd = app.add_subcommand("solve", "Solve an FCLIB local frictional contact problem (HDF5) with our NSGS");
  cmd->add_option("file", opt->file, "FCLIB file (.hdf5)")->required();
  cmd->add_flag("--json", opt->json, "one JSON object: contacts, iterations, error, converged, time_ms");
  cmd->add_option("--tolerance", opt->tolerance, "on the Siconos error")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--max-iterations", opt->max_iterations, "sweep cap")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--over-relaxation", opt->over_relaxation, "omega in (0, 2)")->capture_default_str()->check(CLI::Range(0.01, 1.99));
  cmd->add_option("--order", opt->order, "sweep order")->capture_default_str()->check(CLI::IsMember({"forward", "alternating"}));
  cmd->add_option("--extrapolate-every", opt->extrapolate_every,
                  "sweeps between extrapolation trials along the drift (0: plain NSGS)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->callback([opt, exit_code]() { *exit_code = RunSolve(*opt); });
}

}  // namespace gs::app
