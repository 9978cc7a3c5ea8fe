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

const std::string* Feature(const std::vector<std::string>& lines, const std::string& name) {
  for (const std::string& l : lines)
    if (l.find("\"feature\":\"" + name + "\"") != std::string::npos) return &l;
  return nullptr;
}

TEST(BenchSkip, QuickRunShowsEachSkip) {
  const std::vector<std::string> lines = RunLines("bench skip --quick --json", "bench_skip.json");
  ASSERT_GE(lines.size(), 5u);
  for (size_t i = 0; i + 1 < lines.size(); ++i) {
    EXPECT_GT(Field(lines[i], "with_step_ms_median"), 0.0) << lines[i];
    EXPECT_GT(Field(lines[i], "without_step_ms_median"), 0.0) << lines[i];
    EXPECT_GT(Field(lines[i], "ratio_without_to_with"), 0.0) << lines[i];
  }
  const std::string* friction = Feature(lines, "friction");
  ASSERT_NE(friction, nullptr);
  EXPECT_GT(Field(*friction, "with_local_solves_3d"), 0);
  EXPECT_EQ(Field(*friction, "without_local_solves_3d"), 0);
  EXPECT_GT(Field(*friction, "without_local_solves_normal"), 0);
  const std::string* deformation = Feature(lines, "deformation");
  ASSERT_NE(deformation, nullptr);
  for (const char* k : {"w_deform_sides", "propagations", "deformed_points", "refit_nodes"}) {
    EXPECT_GT(Field(*deformation, std::string("with_") + k), 0) << k;
    EXPECT_EQ(Field(*deformation, std::string("without_") + k), 0) << k;
  }
  const std::string* reuse = Feature(lines, "changed contacts");
  ASSERT_NE(reuse, nullptr);
  EXPECT_EQ(Field(*reuse, "with_w_deform_reused"), 0);
  EXPECT_EQ(Field(*reuse, "without_w_deform_reused"), Field(*reuse, "without_w_deform_sides"));
  const std::string* proximity = Feature(lines, "proximity");
  ASSERT_NE(proximity, nullptr);
  EXPECT_GT(Field(*proximity, "with_pairs_traversed"), 0);
  EXPECT_EQ(Field(*proximity, "without_pairs_traversed"), 0);
  EXPECT_EQ(Field(*proximity, "without_pair_tests"), Field(*proximity, "with_pair_tests"));
  // a resting stack: asleep, every pair reuses its contacts, nothing is tested or traversed
  const std::string* rest = Feature(lines, "rest");
  ASSERT_NE(rest, nullptr);
  EXPECT_EQ(Field(*rest, "with_bodies_asleep"), 0);
  EXPECT_GT(Field(*rest, "with_pairs_traversed"), 0);
  EXPECT_EQ(Field(*rest, "with_pairs_asleep"), 0);
  EXPECT_EQ(Field(*rest, "without_bodies_asleep"), 3);
  EXPECT_EQ(Field(*rest, "without_pair_tests"), 0);
  EXPECT_EQ(Field(*rest, "without_pairs_traversed"), 0);
  EXPECT_EQ(Field(*rest, "without_pairs_asleep"), Field(*rest, "with_pair_tests"));
  EXPECT_GT(Field(*rest, "without_contacts_reused"), 0);
  EXPECT_EQ(Field(*rest, "without_contacts_reused"), Field(*rest, "without_contacts"));
  EXPECT_EQ(Field(*rest, "without_contacts"), Field(*rest, "with_contacts"));
  // the headline
  const std::string& last = lines.back();
  EXPECT_NE(last.find("\"worst_feature\""), std::string::npos) << last;
  EXPECT_GT(Field(last, "worst_ratio_without_to_with"), 0.0) << last;
  EXPECT_EQ(Field(last, "features"), static_cast<double>(lines.size() - 1));
}

}  // namespace
