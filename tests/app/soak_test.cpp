// The soak run in a shortened form (`graspsim bench soak` runs a million steps):
// a looped tracker session holding the box, 20,000 steps. Memory stays flat
// after warm-up, nothing turns NaN, and the box stays in the hand without creeping.
#include "bench/soak.h"

#include <gtest/gtest.h>

#include <filesystem>

namespace gs::app {
namespace {

TEST(Soak, LoopedSessionHoldsTheBoxWithFlatMemory) {
  SoakOptions o;
  o.scene = std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml";
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("graspsim_soak_test_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  o.work_dir = dir.string();
  o.steps = 20000;
  o.warmup_steps = 5000;
  SoakResult r;
  std::string error;
  ASSERT_TRUE(RunSoak(o, &r, &error)) << error;
  std::filesystem::remove_all(dir);
  EXPECT_EQ(r.steps, 20000);
  EXPECT_GE(r.loops, 17) << "the held second was read from the log again and again";
  EXPECT_EQ(r.datagrams, 2000u);
  EXPECT_TRUE(r.finite);
  EXPECT_GT(r.lift_mm, 40.0) << "the box is still held up (the hand lifted it 50 mm)";
  EXPECT_LT(r.drift_rate_um_s, 1.0) << "the held box creeps out of the grasp: " << r.drift_um << " um";
  EXPECT_LT(r.drift_deg, 0.05);
#ifndef GRASPSIM_SANITIZED
  // (under ASan, freed blocks sit in its quarantine, so resident memory grows by design)
  EXPECT_LT(r.rss_growth_mb, 0.25) << "resident " << r.rss_warm_mb << " MB after warm-up, " << r.rss_end_mb << " MB at the end";
#endif
}

TEST(Soak, RefusesAWarmupLongerThanTheRun) {
  SoakOptions o;
  o.scene = std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml";
  o.work_dir = std::filesystem::temp_directory_path().string();
  o.steps = 1000;
  o.warmup_steps = 5000;
  SoakResult r;
  std::string error;
  EXPECT_FALSE(RunSoak(o, &r, &error));
  EXPECT_NE(error.find("warm-up"), std::string::npos) << error;
}

}  // namespace
}  // namespace gs::app
