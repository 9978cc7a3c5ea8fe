// The one place graspsim runs gnuplot (Debian gnuplot-nox; scripts/setup.sh
// installs it): is it there, run a script, report what it said when it fails.
#pragma once

#include <string>

namespace gs::plot {

/// What to tell the user when gnuplot is absent: the package and how to get it.
extern const char* const kGnuplotMissing;

/// True when a `gnuplot` is on the PATH.
bool GnuplotFound();

/// Runs `gnuplot SCRIPT` (stdin closed, so a script can never wait for input).
/// False with *error = "gnuplot failed on SCRIPT: <its output>" when it exits
/// with a non-zero status or cannot be started.
bool RunGnuplot(const std::string& script, std::string* error);

/// `s` as a gnuplot single-quoted string (file names: no escapes inside, a quote doubled).
std::string GpFileName(const std::string& s);
/// `s` as a gnuplot double-quoted string (titles and labels: backslashes and quotes escaped).
std::string GpText(const std::string& s);

}  // namespace gs::plot
