// Pieces shared by the tracker commands (record, send, replay, live, bench
// tracking): Ctrl-C handling, terminal detection, parse-error summaries.
#pragma once

#include <string>

#include "tracking/dtrack_parser.h"

namespace gs::app {

/// SIGINT and SIGTERM set a flag instead of killing the process.
void InstallStopSignals();
bool StopRequested();

/// True when stdout is a terminal (progress bars and status lines only then).
bool StdoutIsTerminal();

/// "0" or "3 (syntax 1, non_finite 2)".
std::string FormatParseErrors(const tracking::ParseStats& s);

/// JSON object of the error counts by category: {"syntax":1,...} (every category).
std::string ParseErrorsJson(const tracking::ParseStats& s);

}  // namespace gs::app
