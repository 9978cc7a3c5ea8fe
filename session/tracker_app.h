// Pieces shared by the tracker commands (record, send, replay, live, bench
// tracking): parse-error summaries (Ctrl-C and terminals: session/console.h).
#pragma once

#include <string>

#include "session/console.h"
#include "tracking/dtrack_parser.h"

namespace gs::app {

/// "0" or "3 (syntax 1, non_finite 2)".
std::string FormatParseErrors(const tracking::ParseStats& s);

/// JSON object of the error counts by category: {"syntax":1,...} (every category).
std::string ParseErrorsJson(const tracking::ParseStats& s);

}  // namespace gs::app
