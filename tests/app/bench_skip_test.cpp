// `graspsim bench skip --quick --json`: one line per feature with both sides'
// medians and work counters, and the skipped work reads zero on the side
// without the feature. Timing figures are not checked here: they belong to the
// benchmark's own output (docs/skip.md).
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

const std::string* Feature(const std::vector<std::string>& lines, const std::string& name) {
  for (const std::string& l : lines)
    if (l.find("\"feature\":\"" + name + "\"") != std::string::npos) return &l;
  return nullptr;
}

TEST(BenchSkip, QuickRunShowsEachSkip) {
  const std::vector<std::string> lines = RunJsonLines("bench skip --quick --json", "bench_skip.json");
  ASSERT_GE(lines.size(), 5u);
  for (size_t i = 0; i + 1 < lines.size(); ++i) {
    EXPECT_GT(JsonField(lines[i], "with_step_ms_median"), 0.0) << lines[i];
    EXPECT_GT(JsonField(lines[i], "without_step_ms_median"), 0.0) << lines[i];
    EXPECT_GT(JsonField(lines[i], "ratio_without_to_with"), 0.0) << lines[i];
  }
  const std::string* friction = Feature(lines, "friction");
  ASSERT_NE(friction, nullptr);
  EXPECT_GT(JsonField(*friction, "with_local_solves_3d"), 0);
  EXPECT_EQ(JsonField(*friction, "without_local_solves_3d"), 0);
  EXPECT_GT(JsonField(*friction, "without_local_solves_normal"), 0);
  const std::string* deformation = Feature(lines, "deformation");
  ASSERT_NE(deformation, nullptr);
  for (const char* k : {"w_deform_sides", "propagations", "deformed_points", "refit_nodes"}) {
    EXPECT_GT(JsonField(*deformation, std::string("with_") + k), 0) << k;
    EXPECT_EQ(JsonField(*deformation, std::string("without_") + k), 0) << k;
  }
  const std::string* reuse = Feature(lines, "changed contacts");
  ASSERT_NE(reuse, nullptr);
  EXPECT_EQ(JsonField(*reuse, "with_w_deform_reused"), 0);
  EXPECT_GT(JsonField(*reuse, "without_w_deform_reused"), 0);
  // the stack at rest: nearly every interpolated side is copied from the last step
  EXPECT_LE(JsonField(*reuse, "without_w_deform_reused") + JsonField(*reuse, "without_w_deform_direct"),
            JsonField(*reuse, "without_w_deform_sides"));
  EXPECT_GE(JsonField(*reuse, "without_w_deform_reused") + JsonField(*reuse, "without_w_deform_direct"),
            0.9 * JsonField(*reuse, "without_w_deform_sides"));
  const std::string* cached = Feature(lines, "pair motion");
  ASSERT_NE(cached, nullptr);
  EXPECT_EQ(JsonField(*cached, "with_pairs_from_cache"), 0);
  EXPECT_GT(JsonField(*cached, "with_pairs_traversed"), 0);
  // at rest the stack's box/box pairs are served from their lists (the box/table pair
  // has none: planes are not cached), with fewer sphere tests
  EXPECT_GT(JsonField(*cached, "without_pairs_from_cache"), 0);
  EXPECT_LT(JsonField(*cached, "without_pairs_from_cache"), JsonField(*cached, "without_pairs_traversed"));
  EXPECT_LT(JsonField(*cached, "without_node_tests"), JsonField(*cached, "with_node_tests"));
  const std::string* proximity = Feature(lines, "proximity");
  ASSERT_NE(proximity, nullptr);
  // near, the balls' pairs pass the broad phase; falling together they stay proven
  // apart by their last detection and are not traversed again (docs/collision.md,
  // "Pairs proven apart")
  EXPECT_GT(JsonField(*proximity, "with_pairs_clear"), 0);
  EXPECT_GE(JsonField(*proximity, "with_pair_tests"),
            JsonField(*proximity, "with_pairs_traversed") + JsonField(*proximity, "with_pairs_clear"));
  EXPECT_EQ(JsonField(*proximity, "without_pairs_traversed"), 0);
  EXPECT_EQ(JsonField(*proximity, "without_pairs_clear"), 0);
  EXPECT_EQ(JsonField(*proximity, "without_pair_tests"), JsonField(*proximity, "with_pair_tests"));
  // a resting stack: asleep, every pair reuses its contacts, nothing is tested or traversed
  const std::string* rest = Feature(lines, "rest");
  ASSERT_NE(rest, nullptr);
  EXPECT_EQ(JsonField(*rest, "with_bodies_asleep"), 0);
  EXPECT_GT(JsonField(*rest, "with_pairs_traversed"), 0);
  EXPECT_EQ(JsonField(*rest, "with_pairs_asleep"), 0);
  EXPECT_EQ(JsonField(*rest, "without_bodies_asleep"), 3);
  EXPECT_EQ(JsonField(*rest, "without_pair_tests"), 0);
  EXPECT_EQ(JsonField(*rest, "without_pairs_traversed"), 0);
  EXPECT_EQ(JsonField(*rest, "without_pairs_asleep"), JsonField(*rest, "with_pair_tests"));
  EXPECT_GT(JsonField(*rest, "without_contacts_reused"), 0);
  EXPECT_EQ(JsonField(*rest, "without_contacts_reused"), JsonField(*rest, "without_contacts"));
  EXPECT_EQ(JsonField(*rest, "without_contacts"), JsonField(*rest, "with_contacts"));
  // the headline
  const std::string& last = lines.back();
  EXPECT_NE(last.find("\"worst_feature\""), std::string::npos) << last;
  EXPECT_GT(JsonField(last, "worst_ratio_without_to_with"), 0.0) << last;
  EXPECT_EQ(JsonField(last, "features"), static_cast<double>(lines.size() - 1));
}

}  // namespace
