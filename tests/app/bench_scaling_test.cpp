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

// the number after "key": in a flat JSON line, NaN when absent
double Field(const std::string& line, const std::string& key) {
  const std::string k = "\"" + key + "\":";
  const size_t at = line.find(k);
  if (at == std::string::npos) return NAN;
  return std::strtod(line.c_str() + at + k.size(), nullptr);
}

TEST(BenchScaling, QuickSeriesAndFittedSlopes) {
  const std::vector<std::string> lines = RunLines("bench scaling --quick --json", "bench_scaling.json");
  ASSERT_FALSE(lines.empty());
  std::vector<double> contacts, point_contacts, points;
  for (const std::string& l : lines) {
    if (l.find("\"series\":\"contacts\"") != std::string::npos) {
      contacts.push_back(Field(l, "contacts"));
      EXPECT_GT(Field(l, "step_ms"), 0.0) << l;
    } else if (l.find("\"series\":\"points\"") != std::string::npos) {
      point_contacts.push_back(Field(l, "contacts"));
      points.push_back(Field(l, "points"));
      EXPECT_GT(Field(l, "step_ms"), 0.0) << l;
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
  EXPECT_TRUE(std::isfinite(Field(last, "loglog_slope_vs_contacts"))) << last;
  EXPECT_TRUE(std::isfinite(Field(last, "step_ms_per_ln_points"))) << last;
  EXPECT_TRUE(std::isfinite(Field(last, "loglog_slope_vs_points"))) << last;
}

}  // namespace
