// `graspsim stress [--json] [--quick] [--case TEXT]`: the numerical stress matrix
// (validate/stress.h). Exit code 0 when every case passes, 1 otherwise.
#include <cstdio>
#include <memory>

#include "app/cli_help.h"
#include "app/commands.h"
#include "session/console.h"
#include "validate/stress.h"

namespace gs::app {

void AddStressCommand(CLI::App& app, int* exit_code) {
  struct Opt {
    bool json = false;
    bool quiet = false;
    std::string filter;
    StressOptions s;
  };
  auto opt = std::make_shared<Opt>();
  CLI::App* cmd = app.add_subcommand(
      "stress", "Numerical stress matrix (stiffness, time step, mass ratio, 2,000 contacts, tracker faults, "
                "degenerate clouds, ...): each case passes or is refused up front");
  cmd->add_flag("--json", opt->json, "one JSON object per case (name, pass, figures), the last line a summary");
  cmd->add_flag("--quiet", opt->quiet, "no line per case: the failed cases and the summary only");
  cmd->add_flag("--quick", opt->s.quick, "shortened runs (100,000 steps instead of a million), under 20 s");
  cmd->add_option("--case", opt->filter, "run only the cases whose name contains NAME (e.g. stiffness, tracker_)")
      ->type_name("NAME");
  SetHelpFooter(cmd,
                {{"graspsim stress --quick", "every case, shortened"},
                 {"graspsim stress --quick --case tracker_ --json", "the tracker teleport and NaN cases as JSON lines"}},
                {{kExitOk, "every case passed (a case refused up front with a clear message passes)"},
                 {kExitFailure, "a case failed (its limits are printed under it)"},
                 {kExitUsage, "bad command line, or no case matches --case (the cases are printed)"},
                 {kExitInterrupted, "interrupted (Ctrl-C, SIGTERM): what was computed up to the stop is written"}});
  cmd->callback([opt, exit_code]() {
    std::string names;
    for (const std::string& n : StressCaseNames()) names += (names.empty() ? "" : ", ") + n;
    bool any = opt->filter.empty();
    for (const std::string& n : StressCaseNames()) any |= n.find(opt->filter) != std::string::npos;
    if (!any) {
      std::fprintf(stderr, "graspsim stress: no case matches '%s' (cases: %s)\n", opt->filter.c_str(), names.c_str());
      *exit_code = kExitUsage;
      return;
    }
    if (!opt->json && !opt->quiet)
      std::printf("%-24s %-6s %7s %6s %5s %5s %5s %9s %10s %10s %9s  %s\n", "case", "result", "steps", "cont", "nan",
                  "rej", "uncv", "resid", "pen (mm)", "dE (J)", "vmax", "check");
    int passed = 0, failed = 0, refused = 0, interrupted = 0;
    double seconds = 0.0;
    for (const std::string& n : StressCaseNames()) {
      if (!opt->filter.empty() && n.find(opt->filter) == std::string::npos) continue;
      std::vector<StressResult> rs = RunStress(opt->s, n);
      for (const StressResult& r : rs) {
        if (r.name != n) continue;  // a filter that is a prefix of a longer name
        (r.interrupted ? interrupted : r.pass ? passed : failed) += 1;
        refused += r.refused ? 1 : 0;
        seconds += r.seconds;
        if (opt->json) {
          std::printf("%s\n", StressJson(r).c_str());
        } else if (opt->quiet && (r.pass || r.interrupted)) {
          continue;
        } else if (r.interrupted) {
          std::printf("%-24s %-6s after %lld steps\n", r.name.c_str(), "STOP", static_cast<long long>(r.steps));
        } else if (r.refused) {
          std::printf("%-24s %-6s refused: %s\n", r.name.c_str(), r.pass ? "PASS" : "FAIL", r.refusal.c_str());
        } else {
          std::printf("%-24s %-6s %7lld %6d %5lld %5lld %5lld %9.2g %10.4f %10.3g %9.3g  %s%s\n", r.name.c_str(),
                      r.pass ? "PASS" : "FAIL", static_cast<long long>(r.steps), r.contacts_max,
                      static_cast<long long>(r.nonfinite_steps), static_cast<long long>(r.rejected_steps),
                      static_cast<long long>(r.unconverged_steps), r.residual_max, 1e3 * r.penetration_max,
                      r.energy_growth, r.speed_max, r.expectation_ok ? "" : "EXPECTATION FAILED: ", r.detail.c_str());
          if (!r.pass) {
            std::printf("%-24s        limits: penetration %.3f mm, energy growth %.3g J; residual check %.2g; %s\n",
                        "", 1e3 * r.penetration_limit, r.energy_limit, r.residual_check, r.what.c_str());
          }
        }
        std::fflush(stdout);
      }
    }
    const bool stopped = StopRequested();
    if (opt->json) {
      std::printf("{\"summary\":\"stress\",\"cases\":%d,\"passed\":%d,\"failed\":%d,\"refused\":%d,\"quick\":%s,"
                  "\"seconds\":%.2f,\"interrupted\":%s,\"pass\":%s}\n",
                  passed + failed, passed, failed, refused, opt->s.quick ? "true" : "false", seconds,
                  stopped ? "true" : "false", failed == 0 && !stopped ? "true" : "false");
    } else {
      std::printf("%d of %d cases passed (%d refused up front), %.1f s%s\n", passed, passed + failed, refused, seconds,
                  stopped ? "; interrupted: the cases after the one stopped were not run" : "");
    }
    *exit_code = stopped ? kExitInterrupted : failed == 0 ? kExitOk : kExitFailure;
  });
}

}  // namespace gs::app
