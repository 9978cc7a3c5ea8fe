// `graspsim validate NAME|all [--json] [--quick]`: physics with known answers.
#include <cstdio>
#include <memory>

#include "app/commands.h"
#include "app/validation.h"

namespace gs::app {

void AddValidateCommand(CLI::App& app, int* exit_code) {
  struct Opt {
    std::string name = "all";
    bool json = false;
    ValidationOptions v;
  };
  auto opt = std::make_shared<Opt>();
  std::string names = "all";
  for (const std::string& n : ValidationNames()) names += "|" + n;
  CLI::App* cmd = app.add_subcommand("validate", "Validation scenes with known answers; prints error and pass/fail");
  cmd->add_option("name", opt->name, names)->capture_default_str();
  cmd->add_flag("--json", opt->json, "one JSON object per case: name, error, pass");
  cmd->add_flag("--quick", opt->v.quick, "shorter holds and coarser sampling");
  cmd->callback([opt, exit_code]() {
    std::vector<ValidationResult> results;
    if (!RunValidation(opt->name, opt->v, &results)) {
      std::fprintf(stderr, "graspsim validate: unknown case '%s' (expected all", opt->name.c_str());
      for (const std::string& n : ValidationNames()) std::fprintf(stderr, ", %s", n.c_str());
      std::fprintf(stderr, ")\n");
      *exit_code = kExitUsage;
      return;
    }
    bool all = true;
    for (const ValidationResult& r : results) {
      all &= r.pass;
      if (opt->json) {
        std::string mode;
        if (!r.contact_mode.empty()) mode = ",\"contact_mode\":\"" + r.contact_mode + "\"";
        std::printf("{\"name\":\"%s\",\"error\":%.6g,\"tolerance\":%.6g,\"unit\":\"%s\",\"pass\":%s%s}\n",
                    r.name.c_str(), r.error, r.tolerance, r.unit.c_str(), r.pass ? "true" : "false", mode.c_str());
      } else {
        std::printf("%-16s %-4s error %.3g %s (tolerance %.3g)  %s\n", r.name.c_str(), r.pass ? "PASS" : "FAIL",
                    r.error, r.unit.c_str(), r.tolerance, r.detail.c_str());
      }
    }
    *exit_code = all ? kExitOk : kExitFailure;
  });
}

}  // namespace gs::app
