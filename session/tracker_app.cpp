#include "session/tracker_app.h"

namespace gs::app {

std::string FormatParseErrors(const tracking::ParseStats& s) {
  std::string out = std::to_string(s.TotalErrors());
  std::string detail;
  for (int i = 0; i < static_cast<int>(tracking::EParseError::Count); ++i) {
    if (!s.errors[i]) continue;
    detail += (detail.empty() ? "" : ", ") + std::string(tracking::ErrorName(static_cast<tracking::EParseError>(i))) +
              " " + std::to_string(s.errors[i]);
  }
  return detail.empty() ? out : out + " (" + detail + ")";
}

std::string ParseErrorsJson(const tracking::ParseStats& s) {
  std::string out = "{";
  for (int i = 0; i < static_cast<int>(tracking::EParseError::Count); ++i) {
    if (i) out += ",";
    out += "\"" + std::string(tracking::ErrorName(static_cast<tracking::EParseError>(i))) +
           "\":" + std::to_string(s.errors[i]);
  }
  return out + "}";
}

}  // namespace gs::app
