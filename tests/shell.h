// Runs a shell command line for the tests (app, tracking, view) and returns its exit status and
// everything it printed (stdout and stderr together).
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace gs::test {

struct ShellResult {
  int code = -1;       ///< exit status, or 128 + signal
  std::string output;  ///< stdout and stderr
};

inline ShellResult Sh(const std::string& cmd) {
  ShellResult r;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

}  // namespace gs::test
