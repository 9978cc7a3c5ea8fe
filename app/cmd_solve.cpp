// `graspsim solve FILE.hdf5 [--json] [--solver nsgs|newton|auto] [--tolerance X]
// [--max-iterations N] [--write-solution OUT.hdf5]`: solves an FCLIB local
// frictional contact problem (core/fc_fallback.h) and prints the iterations,
// the Siconos error of the forces, the time and what ended the solve.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "app/cli_help.h"
#include "app/commands.h"
#include "fclib/fclib_io.h"
#include "core/fc_fallback.h"

namespace gs::app {

struct SolveOptions {
  std::string file;
  bool json = false;
  double tolerance = 1e-6;
  int max_iterations = 100000;
  double over_relaxation = 1.0;
  std::string order = "forward";
  int extrapolate_every = FcSolveParams().nsgs.extrapolate_every;
  std::string solver = "auto";
  int max_newton = FcMethodParams().max_newton;
  int stagnation_window = FcMethodParams().stagnation_window;
  std::string write_solution;
};

EFcMethod ParseMethod(const std::string& s) {
  return s == "nsgs" ? EFcMethod::Nsgs : s == "newton" ? EFcMethod::Newton : EFcMethod::Auto;
}

// the problem and its solution (r, u = W r + q) as an FCLIB file, for other tools to check
bool WriteSolution(const SolveOptions& opt, const FcProblem& p, const Eigen::VectorXd& r, const FcMethodResult& res) {
  std::string error;
  if (!WriteFclibLocal(opt.write_solution, p, "graspsim solve " + opt.file, res.Summary(), &r, &error)) {
    std::fprintf(stderr, "graspsim solve: %s\n", error.c_str());
    return false;
  }
  return true;
}

// --write-solution is checked before the solve: the input itself, or a folder that is
// not there or not writable, is refused before any work
bool CheckSolutionPath(const SolveOptions& opt) {
  if (opt.write_solution.empty()) return true;
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::equivalent(opt.file, opt.write_solution, ec)) {
    std::fprintf(stderr, "graspsim solve: --write-solution %s is the input file; give another path\n",
                 opt.write_solution.c_str());
    return false;
  }
  const fs::path parent = fs::path(opt.write_solution).parent_path();
  const std::string folder = parent.empty() ? std::string(".") : parent.string();
  if (!fs::is_directory(folder, ec) || access(folder.c_str(), W_OK) != 0) {
    std::fprintf(stderr, "graspsim solve: --write-solution %s: folder %s does not exist or is not writable\n",
                 opt.write_solution.c_str(), folder.c_str());
    return false;
  }
  return true;
}

int RunSolve(const SolveOptions& opt) {
  if (!CheckSolutionPath(opt)) return kExitUsage;
  FcProblem p;
  std::string error;
  if (!ReadFclibLocal(opt.file, &p, &error)) {
    std::fprintf(stderr, "graspsim solve: %s\n", error.c_str());
    return kExitBadInput;
  }
  FcMethodParams params;
  params.tolerance = opt.tolerance;
  params.max_sweeps = opt.max_iterations;
  params.max_newton = opt.max_newton;
  params.stagnation_window = opt.stagnation_window;
  params.over_relaxation = opt.over_relaxation;
  params.order = opt.order == "alternating" ? ESweepOrder::Alternating : ESweepOrder::Forward;
  params.extrapolate_every = opt.extrapolate_every;
  Eigen::VectorXd r;
  const FcMethodResult res = SolveFcMethod(p, ParseMethod(opt.solver), params, &r);
  const double error_check = FcError(p, r);
  if (opt.json) {
    std::printf("{\"file\":\"%s\",\"contacts\":%d,\"nnz\":%lld,\"tolerance\":%.3g,\"solver\":\"%s\","
                "\"iterations\":%d,\"newton_iterations\":%d,\"stagnated\":%s,\"error\":%.6g,\"converged\":%s,"
                "\"stop\":\"%s\",\"time_ms\":%.6g,\"nsgs_ms\":%.6g,\"newton_ms\":%.6g,\"extrapolations\":%d}\n",
                opt.file.c_str(), p.contacts, static_cast<long long>(p.W.nonZeros()), opt.tolerance,
                opt.solver.c_str(), res.nsgs.iterations, res.newton.iterations,
                res.nsgs.stagnated ? "true" : "false", error_check, res.converged ? "true" : "false",
                FcStopName(res.stop), 1e3 * res.seconds, 1e3 * res.nsgs_seconds, 1e3 * res.newton_seconds,
                res.nsgs.extrapolations);
  } else {
    std::printf("%s: %d contacts, W %lld non-zeros\n", opt.file.c_str(), p.contacts,
                static_cast<long long>(p.W.nonZeros()));
    std::printf("%s\nerror %.3e (Siconos measure, recomputed), %.3f ms: %s\n", res.Summary().c_str(), error_check,
                1e3 * res.seconds, res.converged ? "converged" : "NOT converged");
  }
  if (!opt.write_solution.empty() && !WriteSolution(opt, p, r, res)) return kExitFailure;
  return res.converged ? kExitOk : kExitFailure;
}

void AddSolveCommand(CLI::App& app, int* exit_code) {
  auto opt = std::make_shared<SolveOptions>();
  CLI::App* cmd = app.add_subcommand("solve", "Solve an FCLIB local frictional contact problem (HDF5)");
  cmd->add_option("file", opt->file, "the FCLIB problem (local formulation)")->type_name("FILE.hdf5")->required();
  cmd->add_flag("--json", opt->json, "one JSON object: contacts, iterations, error, converged, time_ms");
  cmd->add_option("--tolerance", opt->tolerance, "stop at this error (Siconos' measure, dimensionless)")
      ->type_name("ERROR")
      ->capture_default_str()
      ->check(Positive("tolerance"));
  cmd->add_option("--solver", opt->solver,
                  "nsgs (Gauss-Seidel with conjugate directions); newton (proximal semi-smooth Newton, Alart-Curnier); auto (NSGS, then Newton when it stagnates)")
      ->type_name("nsgs|newton|auto")
      ->capture_default_str()
      ->check(OneOf({"nsgs", "newton", "auto"}, "a solver"));
  cmd->add_option("--max-newton", opt->max_newton, "Newton step cap (LU factorisations)")
      ->type_name("N")
      ->capture_default_str()
      ->check(PositiveInt("number of Newton steps"));
  cmd->add_option("--stagnation-window", opt->stagnation_window,
                  "auto: NSGS sweeps per progress check (the best error must halve per window)")
      ->type_name("SWEEPS")
      ->capture_default_str()
      ->check(PositiveInt("number of sweeps"));
  cmd->add_option("--write-solution", opt->write_solution,
                  "write the problem and the forces found (FCLIB solution: r, u = W r + q) to this HDF5 file")
      ->type_name("FILE.hdf5");
  cmd->add_option("--max-iterations", opt->max_iterations, "NSGS sweep cap")
      ->type_name("SWEEPS")
      ->capture_default_str()
      ->check(PositiveInt("number of sweeps"));
  cmd->add_option("--over-relaxation", opt->over_relaxation, "omega, from 0.01 to 1.99")
      ->type_name("OMEGA")
      ->capture_default_str()
      ->check(InRange(0.01, 1.99, "an over-relaxation factor"));
  cmd->add_option("--order", opt->order, "sweep order")
      ->type_name("forward|alternating")
      ->capture_default_str()
      ->check(OneOf({"forward", "alternating"}, "a sweep order"));
  cmd->add_option("--extrapolate-every", opt->extrapolate_every,
                  "sweeps between extrapolation trials along the drift (0: none)")
      ->type_name("SWEEPS")
      ->capture_default_str()
      ->check(NonNegativeInt("number of sweeps"));
  SetHelpFooter(cmd,
                {{"graspsim solve tests/data/fclib/Capsules-i125-1213.hdf5",
                  "iterations, error and time on a problem of the FCLIB collection"},
                 {"graspsim solve tests/data/fclib/Capsules-i125-1213.hdf5 --solver nsgs --json",
                  "NSGS alone, the result as one JSON object"}},
                {{kExitOk, "solved: the error reached --tolerance"},
                 {kExitFailure, "not solved within the caps (--max-iterations, --max-newton), or --write-solution "
                                "could not be written"},
                 {kExitUsage, "bad command line, or a --write-solution path that is the input or in a folder that cannot be written (checked before the solve)"},
                 {kExitBadInput, "the file is not an FCLIB local problem graspsim can read (or FCLIB is not built "
                                 "in)"},
                 {kExitInterrupted, "interrupted (Ctrl-C, SIGTERM): what was computed up to the stop is written"}});
  cmd->callback([opt, exit_code]() { *exit_code = RunSolve(*opt); });
}

}  // namespace gs::app
