// Determinism: the same scene and session give bit-identical results on every
// run, with rendering on or off. Compared by the state hash in summary.json
// (every body's pose, velocity and control-point displacements, finger joints
// and contact forces, bit for bit) and by the hashes of the output files.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "test_util.h"
#include "tracking/session_log.h"
#include "tracking/synthetic_hand.h"

namespace gs::tracking {
namespace {

int CountPngs(const std::string& dir) {
  int n = 0;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) n += e.path().extension() == ".png";
  return n;
}

std::string JsonString(const std::string& text, const std::string& key) {
  const size_t at = text.find("\"" + key + "\":\"");
  if (at == std::string::npos) return "";
  const size_t from = at + key.size() + 4;
  return text.substr(from, text.find('"', from) - from);
}

// a session of the synthetic hand written straight to a log (2.9 s at 100 Hz)
std::string WriteSyntheticSession(const std::string& dir) {
  const std::string path = dir + "/session.lcmlog";
  SessionWriter w;
  std::string error;
  EXPECT_TRUE(w.Open(path, &error)) << error;
  SyntheticHand hand;
  for (uint32_t i = 0; i < 291; ++i) {
    const std::string s = hand.Datagram(i / 100.0, i);
    Datagram d;
    d.data = s.data();
    d.size = s.size();
    d.monotonic_ns = static_cast<int64_t>(i) * 10000000;
    d.utime = d.monotonic_ns / 1000;
    d.sequence = i;
    EXPECT_TRUE(w.Write(d));
  }
  w.Close();
  return path;
}

TEST(Determinism, ReplayIsBitIdenticalAcrossRunsAndWithRendering) {
  const std::string dir = test::TempDir("determinism_replay");
  const std::string log = WriteSyntheticSession(dir);
  const std::string scene = std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml";
  std::string hash[3];
  uint64_t files[3] = {0, 0, 0};
  for (int run = 0; run < 3; ++run) {
    const std::string out = dir + "/out" + std::to_string(run);
    std::string cmd = test::Binary() + " replay " + scene + " " + log + " --duration 1.6 --quiet --out " + out;
    if (run == 2) cmd += " --frames " + dir + "/frames --size 160x120 --fps 10";  // rendering on
    const test::Result r = test::Run(cmd);
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string summary = test::ReadFile(out + "/summary.json");
    hash[run] = JsonString(summary, "state_hash");
    ASSERT_EQ(hash[run].size(), 16u) << summary;
    for (const char* f : {"trajectory.csv", "fingertips.csv", "tracker.csv", "summary.json"})
      files[run] = files[run] * 31 + test::Hash(test::ReadFile(out + "/" + f));
  }
  EXPECT_EQ(hash[0], hash[1]) << "two replays differ";
  EXPECT_EQ(hash[0], hash[2]) << "rendering changed the simulation";
  EXPECT_EQ(files[0], files[1]);
  EXPECT_EQ(files[0], files[2]);
  EXPECT_GE(CountPngs(dir + "/frames"), 15) << "frames were rendered (10 per simulated second)";
}

TEST(Determinism, RunIsBitIdenticalAcrossRunsAndWithRendering) {
  const std::string dir = test::TempDir("determinism_run");
  std::string hash[3];
  for (int run = 0; run < 3; ++run) {
    const std::string out = dir + "/out" + std::to_string(run);
    std::string cmd = test::Binary() + " run config/paper_box_grasp.yaml --duration 0.25 --quiet --out " + out;
    if (run == 2) cmd += " --frames " + dir + "/frames --size 160x120 --fps 20";
    const test::Result r = test::Run(cmd);
    ASSERT_EQ(r.code, 0) << r.output;
    hash[run] = JsonString(test::ReadFile(out + "/summary.json"), "state_hash");
    ASSERT_EQ(hash[run].size(), 16u);
  }
  EXPECT_EQ(hash[0], hash[1]) << "two runs differ";
  EXPECT_EQ(hash[0], hash[2]) << "rendering changed the simulation";
  EXPECT_GE(CountPngs(dir + "/frames"), 5) << "frames were rendered (20 per simulated second)";
}

}  // namespace
}  // namespace gs::tracking
