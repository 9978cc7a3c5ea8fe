// graspsim live with --frames: the render thread draws the frames the 1 kHz
// simulation thread hands over at 30 per simulated second; a frame time is
// either drawn or counted as dropped (the simulation never waits), the files
// on disk are the frames drawn, and the status JSON reports both counts.
// (Whether rendering costs deadlines is a timing figure: live's status and
// docs/render.md report it; this test checks the bookkeeping only.)
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "test_util.h"

namespace gs::tracking {
namespace {

double JsonNumber(const std::string& text, const std::string& key) {
  const size_t at = text.find("\"" + key + "\":");
  if (at == std::string::npos) return NAN;
  return std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

TEST(LiveRender, EveryFrameTimeIsDrawnOrCountedAsDropped) {
  const std::string dir = test::TempDir("live_render");
  const int port = test::FreeUdpPort();
  const std::string scene = std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml";
  test::Background live(test::Binary() + " live " + scene + " --port " + std::to_string(port) +
                        " --duration 2 --publish-rate 0 --size 96x72 --frames " + dir + "/frames");
  ASSERT_NE(live.ReadLine().find("live: scene"), std::string::npos);
  ASSERT_TRUE(live.ReadUntil("live: listening on UDP port " + std::to_string(port))) << live.Wait().output;
  const test::Result send =
      test::Run(test::Binary() + " send --synthetic --rate 100 --port " + std::to_string(port) + " --delay 0");
  const test::Result r = live.Wait();
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string json = r.output.substr(r.output.rfind("{\"live\""));
  EXPECT_NE(json.find("\"rendering\":true"), std::string::npos) << r.output;
  const double drawn = JsonNumber(json, "frames_drawn"), dropped = JsonNumber(json, "frames_dropped");
  const double steps = JsonNumber(json, "steps");
  ASSERT_GT(drawn, 0) << r.output;
  // frame k at k / 30 s of simulated time (1 ms steps), frame 0 at the start
  EXPECT_NEAR(drawn + dropped, std::floor(steps * 1e-3 * 30) + 1, 2.0) << r.output;
  size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/frames")) files += e.path().extension() == ".png";
  EXPECT_EQ(static_cast<double>(files), drawn) << r.output;
  EXPECT_NE(r.output.find("rendered " + std::to_string(static_cast<int>(drawn)) + " frames at 96x72"),
            std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace gs::tracking
