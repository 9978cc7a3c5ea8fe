// The registry of validation families: each family lives in its own file
// (validate/validate_<family>.cpp) and is listed here once.
#include "validate/validation.h"

#include <algorithm>

#include "session/console.h"

namespace gs::app {
namespace {

struct Family {
  const char* name;
  std::vector<ValidationResult> (*run)(const ValidationOptions&);
};

const Family kFamilies[] = {
    {"incline", ValidateIncline},
    {"roll", ValidateRoll},
    {"pinch", ValidatePinch},
    {"slide", ValidateSlide},
    {"hertz", ValidateHertz},
    {"paper-grasp", ValidatePaperGrasp},
    {"stack", ValidateStack},
    {"scale", ValidateScale},
    {"whole-hand", ValidateWholeHand},
};

}  // namespace

std::vector<std::string> ValidationNames() {
  std::vector<std::string> names;
  for (const Family& f : kFamilies) names.push_back(f.name);
  return names;
}

bool RunValidation(const std::string& name, const ValidationOptions& opt, std::vector<ValidationResult>* out) {
  bool known = name == "all";
  for (const Family& f : kFamilies) {
    if (name != "all" && name != f.name) continue;
    known = true;
    if (StopRequested()) break;  // the families after a stop request are not run
    std::vector<ValidationResult> v = f.run(opt);
    out->insert(out->end(), v.begin(), v.end());
  }
  return known;
}

}  // namespace gs::app
