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

#include "json_lines.h"

namespace {

using gs::test::JsonField;
using gs::test::RunJsonLines;

TEST(BenchRealtime, TwoSecondsGiveConsistentCounts) {
  const std::vector<std::string> lines =
      RunJsonLines("bench realtime --seconds 2 --json --scene " + std::string(GRASPSIM_SOURCE_DIR) +
                   "/config/tracked_hand.yaml",
               "bench_realtime.json");
  ASSERT_EQ(lines.size(), 4u);  // without rendering, with rendering, empty loop, headline
  for (const std::string& l : lines) ASSERT_EQ(l.front(), '{') << l;
  const std::string& without = lines[0];
  const std::string& with = lines[1];
  const std::string& empty = lines[2];
  const std::string& last = lines[3];
  EXPECT_NE(empty.find("\"empty_loop\":true"), std::string::npos) << empty;
  EXPECT_NEAR(JsonField(empty, "steps"), 2000, 1) << empty;
  EXPECT_GE(JsonField(empty, "missed_deadlines"), 0) << empty;
  EXPECT_LE(JsonField(empty, "missed_deadlines"), JsonField(empty, "steps")) << empty;
  EXPECT_LE(JsonField(empty, "late_runs"), JsonField(empty, "missed_deadlines")) << empty;
  EXPECT_GE(JsonField(empty, "wake_ms_max"), JsonField(empty, "wake_ms_p99")) << empty;
  EXPECT_EQ(JsonField(last, "empty_loop_missed_deadlines"), JsonField(empty, "missed_deadlines"));
  // the pacing granted is said, whatever it was
  EXPECT_NE(last.find("\"pacing\":\""), std::string::npos) << last;
  EXPECT_NE(without.find("\"rendering\":false"), std::string::npos) << without;
  EXPECT_NE(with.find("\"rendering\":true"), std::string::npos) << with;
  for (const std::string* l : {&without, &with, &last}) {
    EXPECT_NEAR(JsonField(*l, "steps"), 2000, 1) << *l;
    EXPECT_LE(JsonField(*l, "late_runs"), JsonField(*l, "missed_deadlines")) << *l;
    EXPECT_GE(JsonField(*l, "missed_deadlines"), 0) << *l;
    EXPECT_LE(JsonField(*l, "missed_deadlines"), JsonField(*l, "steps")) << *l;
    EXPECT_GT(JsonField(*l, "step_ms_median"), 0) << *l;
  }
  // the session: 100 Hz over 2 s, every datagram applied
  EXPECT_NEAR(JsonField(with, "datagrams"), 200, 1);
  EXPECT_EQ(JsonField(with, "datagrams"), JsonField(without, "datagrams"));
  // frame k at k/30 s: 61 frame times, each drawn or dropped; none without rendering
  EXPECT_NEAR(JsonField(with, "frames_taken"), 61, 1);
  EXPECT_EQ(JsonField(with, "frames") + JsonField(with, "frames_dropped"), JsonField(with, "frames_taken"));
  EXPECT_GT(JsonField(with, "frames"), 0);
  EXPECT_EQ(JsonField(without, "frames_taken"), 0);
  EXPECT_EQ(JsonField(without, "frames"), 0);
  // steps the budget cut short are counted among the unconverged ones, with the error reached
  for (const std::string* l : {&without, &with}) {
    EXPECT_GE(JsonField(*l, "budget_stops"), 0) << *l;
    EXPECT_LE(JsonField(*l, "budget_stops"), JsonField(*l, "unconverged_steps")) << *l;
    EXPECT_LE(JsonField(*l, "unconverged_steps"), JsonField(*l, "steps")) << *l;
    EXPECT_TRUE(std::isfinite(JsonField(*l, "residual_max"))) << *l;
    if (JsonField(*l, "unconverged_steps") > 0) {
      EXPECT_GT(JsonField(*l, "residual_max"), 0) << *l;
    }
  }
  // every missed deadline has one cause: the step's own work, a late start, or catching up
  for (const std::string* l : {&without, &with, &last}) {
    EXPECT_EQ(JsonField(*l, "missed_own_work") + JsonField(*l, "missed_woke_late") + JsonField(*l, "missed_carried"),
              JsonField(*l, "missed_deadlines"))
        << *l;
    // a step longer than a timestep is late only once it has used up the lead (see the
    // steps CSV test for the lead of 0, where every one of them is)
    EXPECT_LE(JsonField(*l, "overlong_steps"), JsonField(*l, "steps")) << *l;
  }
  // steps whose pairs carried their contacts after steps past the budget: at most two in three
  for (const std::string* l : {&without, &with}) {
    EXPECT_GE(JsonField(*l, "carried_contact_steps"), 0) << *l;
    EXPECT_LE(3 * JsonField(*l, "carried_contact_steps"), 2 * JsonField(*l, "steps") + 2) << *l;
  }
  EXPECT_EQ(JsonField(last, "carried_contact_steps"), JsonField(with, "carried_contact_steps"));
  EXPECT_EQ(JsonField(last, "no_render_carried_contact_steps"), JsonField(without, "carried_contact_steps"));
  EXPECT_EQ(JsonField(last, "no_render_missed_own_work"), JsonField(without, "missed_own_work"));
  EXPECT_EQ(JsonField(last, "budget_stops"), JsonField(with, "budget_stops"));
  EXPECT_EQ(JsonField(last, "step_budget"), 0.8);
  EXPECT_EQ(JsonField(last, "lead_steps"), 1);  // live's default (session/pacing.h StepSchedule)
  // the hypervisor's steal time on the loop's core, read from /proc/stat (a count, never negative there)
  if (FILE* stat = std::fopen("/proc/stat", "r")) {
    std::fclose(stat);
    for (const std::string* l : {&without, &with, &empty}) EXPECT_GE(JsonField(*l, "steal_ms"), 0) << *l;
  }
  // the grasp happens in both; the replay is deterministic in simulated time unless the
  // step budget (a wall-clock limit) cut a solve short in either run
  EXPECT_GT(JsonField(with, "max_contacts"), 0);
  if (JsonField(with, "budget_stops") == 0 && JsonField(without, "budget_stops") == 0) {
    EXPECT_EQ(JsonField(with, "max_contacts"), JsonField(without, "max_contacts"));
    EXPECT_EQ(JsonField(with, "lifts"), JsonField(without, "lifts"));
  }
  // the headline repeats the rendering run and puts the other beside it
  EXPECT_EQ(JsonField(last, "missed_deadlines"), JsonField(with, "missed_deadlines"));
  EXPECT_EQ(JsonField(last, "frames"), JsonField(with, "frames"));
  EXPECT_EQ(JsonField(last, "no_render_missed_deadlines"), JsonField(without, "missed_deadlines"));
  EXPECT_NE(last.find("\"target_met\""), std::string::npos) << last;
}

// --detect-every-step: no step carries contacts, whatever the machine's speed
TEST(BenchRealtime, DetectEveryStepCarriesNoContacts) {
  const std::vector<std::string> lines =
      RunJsonLines("bench realtime --seconds 0.5 --detect-every-step --json --scene " + std::string(GRASPSIM_SOURCE_DIR) +
                       "/config/tracked_hand.yaml",
                   "bench_realtime_detect.json");
  ASSERT_EQ(lines.size(), 4u);
  for (int i : {0, 1}) EXPECT_EQ(JsonField(lines[i], "carried_contact_steps"), 0) << lines[i];
  EXPECT_EQ(JsonField(lines[3], "no_render_carried_contact_steps"), 0) << lines[3];
}

// --steps-csv: one line per step of each run, rendering first, its late steps
// those the run counted as missed deadlines. Each step's lateness is its wake-up
// lateness (from its release) plus its loop time less the time from its release to
// its deadline: one timestep with --lead-steps 0, two with --lead-steps 1.
TEST(BenchRealtime, StepsCsvHoldsEveryStepOfBothRuns) {
  for (int lead : {0, 1}) {
    SCOPED_TRACE("--lead-steps " + std::to_string(lead));
    const std::string csv = std::string(::testing::TempDir()) + "/bench_realtime_steps.csv";
    std::remove(csv.c_str());
    const std::vector<std::string> lines =
        RunJsonLines("bench realtime --seconds 0.5 --lead-steps " + std::to_string(lead) + " --json --steps-csv " +
                         csv + " --scene " + std::string(GRASPSIM_SOURCE_DIR) + "/config/tracked_hand.yaml",
                     "bench_realtime_steps.json");
    ASSERT_EQ(lines.size(), 4u);
    EXPECT_EQ(JsonField(lines[3], "lead_steps"), lead);
    if (lead == 0) {
      // without a lead, a step longer than a timestep misses its deadline by its own work
      for (int i : {0, 1}) EXPECT_LE(JsonField(lines[i], "overlong_steps"), JsonField(lines[i], "missed_own_work")) << lines[i];
    }
    FILE* f = std::fopen(csv.c_str(), "r");
    ASSERT_NE(f, nullptr) << csv;
    char buf[4096];
    ASSERT_NE(std::fgets(buf, sizeof buf, f), nullptr);
    const std::string header = buf;
    EXPECT_EQ(header.rfind("rendering,step,wake_ms,loop_ms,late_ms,", 0), 0u) << header;
    int columns = 1;
    for (char c : header) columns += c == ',' ? 1 : 0;
    int rows[2] = {0, 0}, late[2] = {0, 0}, order_errors = 0;
    bool saw_without = false;
    while (std::fgets(buf, sizeof buf, f)) {
      int fields = 1;
      for (const char* c = buf; *c; ++c) fields += *c == ',' ? 1 : 0;
      EXPECT_EQ(fields, columns) << buf;
      int rendering = -1;
      long long step = -1;
      double wake = 0, loop = -1, late_ms = 0;
      ASSERT_EQ(std::sscanf(buf, "%d,%lld,%lf,%lf,%lf", &rendering, &step, &wake, &loop, &late_ms), 5) << buf;
      ASSERT_TRUE(rendering == 0 || rendering == 1) << buf;
      if (rendering == 0) saw_without = true;
      if (rendering == 1 && saw_without) ++order_errors;  // the rendering run comes first
      EXPECT_EQ(step, rows[rendering]) << buf;             // every step, in order
      EXPECT_GT(loop, 0.0) << buf;
      EXPECT_GE(wake, 0.0) << buf;  // no step begins before its release
      // the three columns come from the same two clock readings (each to the nanosecond, so that a
      // step late by a few ns is late in the file too)
      EXPECT_NEAR(late_ms, wake + loop - (1 + lead), 3e-6) << buf;
      ++rows[rendering];
      late[rendering] += late_ms > 0.0 ? 1 : 0;
    }
    std::fclose(f);
    EXPECT_EQ(order_errors, 0);
    EXPECT_EQ(rows[1], 500);
    EXPECT_EQ(rows[0], 500);
    EXPECT_EQ(late[0], JsonField(lines[0], "missed_deadlines"));
    EXPECT_EQ(late[1], JsonField(lines[1], "missed_deadlines"));
  }
}

// a file that cannot be written is said, with its name, and no run is lost silently
TEST(BenchRealtime, UnwritableStepsCsvIsAClearError) {
  const std::string err = std::string(::testing::TempDir()) + "/bench_realtime_csv_err.txt";
  const std::string cmd = std::string(GRASPSIM_BINARY) +
                          " bench realtime --seconds 0.1 --steps-csv /nonexistent-dir/steps.csv --scene " +
                          std::string(GRASPSIM_SOURCE_DIR) + "/config/tracked_hand.yaml > /dev/null 2> " + err;
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 3);
  FILE* f = std::fopen(err.c_str(), "r");
  ASSERT_NE(f, nullptr);
  char buf[1024] = "";
  const size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  buf[n] = 0;
  EXPECT_NE(std::string(buf).find("/nonexistent-dir/steps.csv"), std::string::npos) << buf;
}

TEST(BenchRealtime, RefusesASceneWithoutATracker) {
  const std::string cmd = std::string(GRASPSIM_BINARY) + " bench realtime --seconds 0.2 --scene " +
                          std::string(GRASPSIM_SOURCE_DIR) + "/config/paper_box_grasp.yaml > /dev/null 2>&1";
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 3);
}

}  // namespace
