#include "plot/gnuplot.h"

#include <cstdio>
#include <cstdlib>

namespace gs::plot {
namespace {

// a path as one word for /bin/sh: single quotes, and each quote inside closed, escaped, reopened
std::string ShellWord(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

}  // namespace

const char* const kGnuplotMissing =
    "gnuplot is not installed (Debian: apt-get install gnuplot-nox, or run scripts/setup.sh)";

bool GnuplotFound() { return std::system("command -v gnuplot >/dev/null 2>&1") == 0; }

bool RunGnuplot(const std::string& script, std::string* error) {
  const std::string cmd = "gnuplot " + ShellWord(script) + " </dev/null 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  if (p) {
    char buf[512];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
  }
  const int rc = p ? pclose(p) : -1;
  if (rc == 0) return true;
  *error = "gnuplot failed on " + script + (out.empty() ? std::string() : ": " + out);
  return false;
}

std::string GpFileName(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("''") : std::string(1, c);
  return o + "'";
}

std::string GpText(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    o += c == '\n' ? ' ' : c;
  }
  return o + "\"";
}

}  // namespace gs::plot
