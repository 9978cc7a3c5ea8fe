// `graspsim bench step --from S --seconds L`: the timed window is the one asked for
// (its start and length in the headline, its step count), and a window that cannot
// be timed is refused on the command line. Timing figures are not checked here.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "json_lines.h"

namespace {

using gs::test::JsonField;
using gs::test::RunJsonLines;

TEST(BenchStep, TimesTheWindowItIsGiven) {
  const std::vector<std::string> lines =
      RunJsonLines("bench step --json --from 0.25 --seconds 0.02", "bench_step_window.json");
  ASSERT_FALSE(lines.empty());
  const std::string& last = lines.back();
  EXPECT_DOUBLE_EQ(JsonField(last, "from_s"), 0.25) << last;
  EXPECT_DOUBLE_EQ(JsonField(last, "seconds"), 0.02) << last;
  EXPECT_EQ(JsonField(last, "steps"), 20) << last;  // the paper grasp steps at 1 ms
  // the quantiles are ordered
  EXPECT_LE(JsonField(last, "step_ms_median"), JsonField(last, "step_ms_p90")) << last;
  EXPECT_LE(JsonField(last, "step_ms_p90"), JsonField(last, "step_ms_max")) << last;
  EXPECT_GE(JsonField(last, "refit_ms_median"), 0.0) << last;
}

TEST(BenchStep, WithoutAWindowTimesTheHold) {
  const std::vector<std::string> lines = RunJsonLines("bench step --json --quick", "bench_step_hold.json");
  ASSERT_FALSE(lines.empty());
  EXPECT_DOUBLE_EQ(JsonField(lines.back(), "from_s"), 1.0) << lines.back();  // the scripted grasp's hold
  EXPECT_EQ(JsonField(lines.back(), "steps"), 200) << lines.back();
}

TEST(BenchStep, RefusesAWindowThatCannotBeTimed) {
  for (const char* bad : {"--seconds 0", "--seconds -1", "--from -0.5", "--seconds nan"}) {
    const std::string err = std::string(::testing::TempDir()) + "/bench_step_bad.txt";
    const std::string cmd = std::string(GRASPSIM_BINARY) + " bench step --json " + bad + " > /dev/null 2> " + err;
    const int status = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(status)) << cmd;
    EXPECT_EQ(WEXITSTATUS(status), 2) << cmd;
    FILE* f = std::fopen(err.c_str(), "r");
    ASSERT_NE(f, nullptr);
    char buf[4096] = {};
    const size_t n = std::fread(buf, 1, sizeof buf - 1, f);
    std::fclose(f);
    const std::string text(buf, n);
    const std::string option = std::string(bad).substr(0, std::string(bad).find(' '));
    EXPECT_NE(text.find(option), std::string::npos) << cmd << ": " << text;
  }
}

}  // namespace
