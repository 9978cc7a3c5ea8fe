// Helpers of the app tests that run `graspsim ... --json` and read its output:
// one flat JSON object per line.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace gs::test {

/// Runs `graspsim ARGS` with stdout into TempDir()/FILE (a failing exit status
/// fails the test) and returns its non-empty lines.
inline std::vector<std::string> RunJsonLines(const std::string& args, const std::string& file) {
  const std::string out = std::string(::testing::TempDir()) + "/" + file;
  const std::string cmd = std::string(GRASPSIM_BINARY) + " " + args + " > " + out;
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::vector<std::string> lines;
  FILE* f = std::fopen(out.c_str(), "r");
  if (!f) return lines;
  char buf[8192];
  while (std::fgets(buf, sizeof buf, f)) {
    std::string l = buf;
    while (!l.empty() && (l.back() == '\n' || l.back() == '\r')) l.pop_back();
    if (!l.empty()) lines.push_back(l);
  }
  std::fclose(f);
  return lines;
}

/// The number after "key": in a flat JSON line; NaN when absent.
inline double JsonField(const std::string& line, const std::string& key) {
  const std::string k = "\"" + key + "\":";
  const size_t at = line.find(k);
  if (at == std::string::npos) return NAN;
  return std::strtod(line.c_str() + at + k.size(), nullptr);
}

}  // namespace gs::test
