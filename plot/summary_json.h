// summary.json of a run or replay folder, as far as plotting needs it. The
// whole file must be one JSON object (a truncated or edited file is refused with
// its line); members plot does not use, nested or not, are checked and skipped.
#pragma once

#include <map>
#include <string>

namespace gs::plot {

struct Summary {
  std::map<std::string, double> numbers;       ///< top-level number members (dt_s, steps, ...)
  std::map<std::string, std::string> strings;  ///< top-level string members (tracked_body, log, ...)
};

/// False with "PATH:LINE: what is wrong" in *error.
bool ReadSummary(const std::string& path, Summary* summary, std::string* error);
/// The same on text already read (`path` names it in errors).
bool ParseSummary(const std::string& text, const std::string& path, Summary* summary, std::string* error);

}  // namespace gs::plot
