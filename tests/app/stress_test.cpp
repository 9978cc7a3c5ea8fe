// The stress matrix (validate/stress.h) in its shortened form: every case passes or
// is refused up front for the stated reason. Under sanitizers the test-only
// `tiny` form runs (shorter, coarser), so that the suite stays fast.
#include "validate/stress.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "scene/scene_checks.h"

namespace gs::app {
namespace {

StressOptions TestOptions() {
  StressOptions o;
#ifdef GRASPSIM_SANITIZED
  o.tiny = true;
#else
  o.quick = true;
#endif
  return o;
}

const std::vector<StressResult>& Results() {
  static const std::vector<StressResult> results = RunStress(TestOptions());
  return results;
}

const StressResult& Find(const std::string& name) {
  for (const StressResult& r : Results())
    if (r.name == name) return r;
  static StressResult missing;
  ADD_FAILURE() << "no stress case " << name;
  return missing;
}

// one test, so that ctest's one-process-per-test runs the matrix once
TEST(Stress, QuickMatrix) {
  ASSERT_EQ(Results().size(), StressCaseNames().size());
  for (const StressResult& r : Results()) {
    EXPECT_TRUE(r.pass) << StressJson(r);
    EXPECT_EQ(r.nonfinite_steps, 0) << r.name;
    EXPECT_EQ(r.misreported_steps, 0) << r.name;
    if (!r.refused) {
      EXPECT_GT(r.steps, 0) << r.name;
      EXPECT_LE(r.penetration_max, r.penetration_limit) << r.name;
      EXPECT_LE(r.energy_growth, r.energy_limit) << r.name;
    }
  }

  // ill-posed scenes are refused with their reason

  const StressResult& dt = Find("dt_0.05");
  EXPECT_TRUE(dt.refused);
  EXPECT_NE(dt.refusal.find("time step 0.05 s is too long"), std::string::npos) << dt.refusal;
  // the body that needs the shortest step (the smaller box, with the smaller leaves)
  EXPECT_NE(dt.refusal.find("body 'high'"), std::string::npos) << dt.refusal;
  const StressResult& deep = Find("deep_penetration_boxes");
  EXPECT_TRUE(deep.refused);
  EXPECT_NE(deep.refusal.find("bodies 'low' and 'high' start overlapping"), std::string::npos) << deep.refusal;
  // the well-posed neighbours are not refused
  EXPECT_FALSE(Find("dt_1e-2").refused);
  EXPECT_FALSE(Find("deep_penetration_plane").refused);

  // the cases do what they say
  EXPECT_GE(Find("contacts_2000").contacts_max, 2000);
  // a ball started 4 mm inside a plane leaves at the bounded push-out speed, not at 4 m/s
  const StressResult& plane = Find("deep_penetration_plane");
  EXPECT_GT(plane.penetration_max, 1e-3);
  EXPECT_LE(plane.speed_max, 0.1 + 9.81e-3);  // plus one step of gravity
  // corrupt tracker samples are ignored by the coupling: no step had to be undone
  EXPECT_EQ(Find("tracker_nan").rejected_steps, 0);
  EXPECT_GT(Find("million_steps").steps, 1000);
  // the residual the solver reports is the Siconos error of an explicitly assembled W
  for (const StressResult& r : Results())
    if (!r.refused) {
      EXPECT_LE(r.residual_check, 1e-3) << r.name;
    }
}

TEST(Stress, JsonHasNameAndPass) {
  StressResult r;
  r.name = "x\"y";
  r.pass = true;
  r.penetration_max = NAN;
  const std::string j = StressJson(r);
  EXPECT_EQ(j.rfind("{\"name\":\"x\\\"y\",\"pass\":true", 0), 0u) << j;
  EXPECT_NE(j.find("\"penetration_max_m\":null"), std::string::npos) << j;
}

TEST(Stress, CommandLine) {
  const std::string out =
      (std::filesystem::temp_directory_path() / ("graspsim_stress_" + std::to_string(::getpid()))).string();
  std::string cmd = std::string(GRASPSIM_BINARY) + " stress --json --case mu_0 > " + out;
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(out);
  std::string first, last, line;
  std::getline(in, first);
  last = first;
  while (std::getline(in, line)) last = line;
  EXPECT_EQ(first.rfind("{\"name\":\"mu_0\",\"pass\":true", 0), 0u) << first;
  EXPECT_NE(last.find("\"summary\":\"stress\""), std::string::npos) << last;
  EXPECT_NE(last.find("\"failed\":0"), std::string::npos) << last;
  cmd = std::string(GRASPSIM_BINARY) + " stress --case no_such_case 2> " + out;
  EXPECT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 2);
  std::ifstream err(out);
  std::getline(err, line);
  EXPECT_NE(line.find("no case matches 'no_such_case'"), std::string::npos) << line;
  std::remove(out.c_str());
}

}  // namespace
}  // namespace gs::app
