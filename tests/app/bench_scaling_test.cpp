// `graspsim bench scaling --quick --json`: the series cover what they say (the
// contact count grows with the slab, the point series keeps its contact count)
// and the headline holds finite fitted slopes. Timing figures are not checked
// here: they belong to the benchmark's own output.
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

TEST(BenchScaling, QuickSeriesAndFittedSlopes) {
  const std::vector<std::string> lines = RunJsonLines("bench scaling --quick --json", "bench_scaling.json");
  ASSERT_FALSE(lines.empty());
  std::vector<double> contacts, point_contacts, points;
  for (const std::string& l : lines) {
    if (l.find("\"series\":\"contacts\"") != std::string::npos) {
      contacts.push_back(JsonField(l, "contacts"));
      EXPECT_GT(JsonField(l, "step_ms"), 0.0) << l;
    } else if (l.find("\"series\":\"points\"") != std::string::npos) {
      point_contacts.push_back(JsonField(l, "contacts"));
      points.push_back(JsonField(l, "points"));
      EXPECT_GT(JsonField(l, "step_ms"), 0.0) << l;
    }
  }
  ASSERT_GE(contacts.size(), 3u);
  // from about 50 contacts up, each slab at least 1.5x the contacts of the last
  EXPECT_GE(contacts.front(), 30);
  EXPECT_LE(contacts.front(), 100);
  for (size_t i = 1; i < contacts.size(); ++i) EXPECT_GT(contacts[i], 1.5 * contacts[i - 1]);
  ASSERT_GE(point_contacts.size(), 2u);
  EXPECT_GE(points.front(), 10000);
  for (size_t i = 1; i < points.size(); ++i) {
    EXPECT_GT(points[i], points[i - 1]);
    // a fixed contact count: what grows is the point count, not the contacts
    EXPECT_NEAR(point_contacts[i], point_contacts[0], 0.3 * point_contacts[0]);
  }
  EXPECT_GT(point_contacts[0], 10);
  const std::string& last = lines.back();
  EXPECT_NE(last.find("\"bench\":\"scaling\""), std::string::npos) << last;
  EXPECT_TRUE(std::isfinite(JsonField(last, "loglog_slope_vs_contacts"))) << last;
  EXPECT_TRUE(std::isfinite(JsonField(last, "step_ms_per_ln_points"))) << last;
  EXPECT_TRUE(std::isfinite(JsonField(last, "loglog_slope_vs_points"))) << last;
}

}  // namespace
