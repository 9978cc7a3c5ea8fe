// `graspsim validate NAME|all [--json] [--quick]`: physics with known answers.
#include <algorithm>
#include <cstdio>
#include <memory>

#include "app/cli_help.h"
#include "app/commands.h"
#include "session/console.h"
#include "validate/validation.h"

namespace gs::app {

namespace {

void PrintResult(const ValidationResult& r, bool json) {
  if (json) {
    std::string mode;
    if (!r.contact_mode.empty()) mode = ",\"contact_mode\":\"" + r.contact_mode + "\"";
    if (r.interrupted) mode += ",\"interrupted\":true";
    // a case cut short by a stop has no verdict: pass is null, as the text's STOP line says
    const char* pass = r.interrupted ? "null" : r.pass ? "true" : "false";
    std::printf("{\"name\":\"%s\",\"error\":%.6g,\"tolerance\":%.6g,\"unit\":\"%s\",\"pass\":%s%s}\n",
                r.name.c_str(), r.error, r.tolerance, r.unit.c_str(), pass, mode.c_str());
  } else if (r.interrupted) {
    std::printf("%-16s STOP interrupted before its end: no verdict\n", r.name.c_str());
  } else {
    std::printf("%-16s %-4s error %.3g %s (tolerance %.3g)  %s\n", r.name.c_str(), r.pass ? "PASS" : "FAIL", r.error,
                r.unit.c_str(), r.tolerance, r.detail.c_str());
  }
}

}  // namespace

void AddValidateCommand(CLI::App& app, int* exit_code) {
  struct Opt {
    std::string name = "all";
    bool json = false;
    bool quiet = false;
    ValidationOptions v;
  };
  auto opt = std::make_shared<Opt>();
  std::string names;
  for (const std::string& n : ValidationNames()) names += ", " + n;
  CLI::App* cmd = app.add_subcommand("validate", "Validation scenes with known answers; prints error and pass/fail");
  cmd->add_option("name", opt->name, "all, or one family of cases: " + names.substr(2))
      ->type_name("CASE")
      ->capture_default_str();
  cmd->add_flag("--json", opt->json, "one JSON object per case: name, error, pass (null for a case a stop cut short, marked interrupted)");
  cmd->add_flag("--quick", opt->v.quick, "shorter holds and coarser sampling");
  cmd->add_flag("--quiet", opt->quiet, "no line announcing each family");
  SetHelpFooter(cmd,
                {{"graspsim validate slide --quick", "the sliding cases (friction over normal force while sliding, against mu), shortened"},
                 {"graspsim validate --json", "every family (it takes minutes), one JSON object per case"}},
                {{kExitOk, "every case passed"},
                 {kExitFailure, "a case failed: its error is over its bound (the FAIL lines)"},
                 {kExitUsage, "bad command line, or an unknown CASE (the families are printed)"},
                 {kExitInterrupted, "interrupted (Ctrl-C, SIGTERM): what was computed up to the stop is written"}});
  cmd->callback([opt, exit_code]() {
    const std::vector<std::string> families = ValidationNames();
    const bool known = opt->name == "all" || std::find(families.begin(), families.end(), opt->name) != families.end();
    if (!known) {
      std::fprintf(stderr, "graspsim validate: unknown case '%s' (expected all", opt->name.c_str());
      for (const std::string& n : families) std::fprintf(stderr, ", %s", n.c_str());
      std::fprintf(stderr, ")\n");
      *exit_code = kExitUsage;
      return;
    }
    // family by family, each printed as soon as it is done (all takes minutes)
    int passed = 0, failed = 0, stopped = 0;
    std::vector<std::string> not_run;
    for (const std::string& family : families) {
      if (opt->name != "all" && opt->name != family) continue;
      if (StopRequested()) {
        not_run.push_back(family);
        continue;
      }
      if (!opt->json && !opt->quiet) std::printf("validate %s ...\n", family.c_str());
      std::vector<ValidationResult> results;
      RunValidation(family, opt->v, &results);
      for (const ValidationResult& r : results) {
        (r.interrupted ? stopped : r.pass ? passed : failed) += 1;
        PrintResult(r, opt->json);
      }
    }
    if (!opt->json) {
      std::printf("validate: %d passed, %d failed", passed, failed);
      if (StopRequested()) {
        std::printf("; interrupted: %d cases without a verdict", stopped);
        for (size_t i = 0; i < not_run.size(); ++i)
          std::printf("%s%s", i == 0 ? "; not run: " : ", ", not_run[i].c_str());
      }
      std::printf("\n");
    }
    *exit_code = StopRequested() ? kExitInterrupted : failed == 0 ? kExitOk : kExitFailure;
  });
}

}  // namespace gs::app
