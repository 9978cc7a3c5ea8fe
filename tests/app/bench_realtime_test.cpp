// `graspsim bench realtime --seconds 2 --json` (on the tenth-density tracked
// scene, to keep the test short): the counts are consistent (one step per
// millisecond of the session, 30 frame times per second, each drawn or dropped,
// the same steps without rendering and in the empty loop), not the timing:
// deadlines belong to the benchmark's own figures (docs/benchmarks.md).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

std::vector<std::string> RunLines(const std::string& args, const std::string& file) {
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

double Field(const std::string& line, const std::string& key) {
  const std::string k = "\"" + key + "\":";
  const size_t at = line.find(k);
  if (at == std::string::npos) return NAN;
  return std::strtod(line.c_str() + at + k.size(), nullptr);
}

TEST(BenchRealtime, TwoSecondsGiveConsistentCounts) {
  const std::vector<std::string> lines =
      RunLines("bench realtime --seconds 2 --json --scene " + std::string(GRASPSIM_SOURCE_DIR) +
                   "/config/tracked_hand.yaml",
               "bench_realtime.json");
  ASSERT_EQ(lines.size(), 4u);  // without rendering, with rendering, empty loop, headline
  for (const std::string& l : lines) ASSERT_EQ(l.front(), '{') << l;
  const std::string& without = lines[0];
  const std::string& with = lines[1];
  const std::string& empty = lines[2];
  const std::string& last = lines[3];
  EXPECT_NE(empty.find("\"empty_loop\":true"), std::string::npos) << empty;
  EXPECT_NEAR(Field(empty, "steps"), 2000, 1) << empty;
  EXPECT_GE(Field(empty, "missed_deadlines"), 0) << empty;
  EXPECT_LE(Field(empty, "missed_deadlines"), Field(empty, "steps")) << empty;
  EXPECT_LE(Field(empty, "late_runs"), Field(empty, "missed_deadlines")) << empty;
  EXPECT_GE(Field(empty, "wake_ms_max"), Field(empty, "wake_ms_p99")) << empty;
  EXPECT_EQ(Field(last, "empty_loop_missed_deadlines"), Field(empty, "missed_deadlines"));
  // the pacing granted is said, whatever it was
  EXPECT_NE(last.find("\"pacing\":\""), std::string::npos) << last;
  EXPECT_NE(without.find("\"rendering\":false"), std::string::npos) << without;
  EXPECT_NE(with.find("\"rendering\":true"), std::string::npos) << with;
  for (const std::string* l : {&without, &with, &last}) {
    EXPECT_NEAR(Field(*l, "steps"), 2000, 1) << *l;
    EXPECT_LE(Field(*l, "late_runs"), Field(*l, "missed_deadlines")) << *l;
    EXPECT_GE(Field(*l, "missed_deadlines"), 0) << *l;
    EXPECT_LE(Field(*l, "missed_deadlines"), Field(*l, "steps")) << *l;
    EXPECT_GT(Field(*l, "step_ms_median"), 0) << *l;
  }
  // the session: 100 Hz over 2 s, every datagram applied
  EXPECT_NEAR(Field(with, "datagrams"), 200, 1);
  EXPECT_EQ(Field(with, "datagrams"), Field(without, "datagrams"));
  // frame k at k/30 s: 61 frame times, each drawn or dropped; none without rendering
  EXPECT_NEAR(Field(with, "frames_taken"), 61, 1);
  EXPECT_EQ(Field(with, "frames") + Field(with, "frames_dropped"), Field(with, "frames_taken"));
  EXPECT_GT(Field(with, "frames"), 0);
  EXPECT_EQ(Field(without, "frames_taken"), 0);
  EXPECT_EQ(Field(without, "frames"), 0);
  // the replay is deterministic in simulated time: the grasp happens in both
  EXPECT_GT(Field(with, "max_contacts"), 0);
  EXPECT_EQ(Field(with, "max_contacts"), Field(without, "max_contacts"));
  EXPECT_EQ(Field(with, "lifts"), Field(without, "lifts"));
  // the headline repeats the rendering run and puts the other beside it
  EXPECT_EQ(Field(last, "missed_deadlines"), Field(with, "missed_deadlines"));
  EXPECT_EQ(Field(last, "frames"), Field(with, "frames"));
  EXPECT_EQ(Field(last, "no_render_missed_deadlines"), Field(without, "missed_deadlines"));
  EXPECT_NE(last.find("\"target_met\""), std::string::npos) << last;
}

TEST(BenchRealtime, RefusesASceneWithoutATracker) {
  const std::string cmd = std::string(GRASPSIM_BINARY) + " bench realtime --seconds 0.2 --scene " +
                          std::string(GRASPSIM_SOURCE_DIR) + "/config/paper_box_grasp.yaml > /dev/null 2>&1";
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 3);
}

}  // namespace
