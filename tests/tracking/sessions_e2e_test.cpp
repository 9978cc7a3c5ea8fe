// End to end through the graspsim binary: send --synthetic into record, then
// replay the recording twice: the box is grasped and lifted, and the two
// replays write bit-identical files.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>
#include <thread>

#include "test_util.h"

namespace gs::tracking {
namespace {

using test::Binary;

TEST(SessionsEndToEnd, SendRecordReplayGraspsLiftsAndIsDeterministic) {
  const std::string dir = test::TempDir("e2e");
  const std::string log = dir + "/session.lcmlog";
  const int port = test::FreeUdpPort();
  test::Background record(Binary() + " record --quiet --port " + std::to_string(port) + " -o " + log +
                          " --duration 6");
  // send only once the socket is open (a fixed wait lost the first datagrams under ASan on a
  // loaded CI machine); the 2.9 s session then fits in the duration with room to spare
  ASSERT_NE(record.ReadLine().find("record: listening"), std::string::npos);
  const test::Result send = test::Run(Binary() + " send --synthetic --port " + std::to_string(port));
  ASSERT_EQ(send.code, 0) << send.output;
  const test::Result rec = record.Wait();
  ASSERT_EQ(rec.code, 0) << rec.output;
  EXPECT_NE(rec.output.find("record: 291 datagrams"), std::string::npos) << rec.output;
  EXPECT_NE(rec.output.find("parse errors 0"), std::string::npos) << rec.output;

  // the grasp and lift are over by 2 s of the session
  std::string summary[2];
  uint64_t hashes[2] = {0, 0};
  for (int run = 0; run < 2; ++run) {
    const std::string out = dir + "/replay" + std::to_string(run);
    const test::Result r = test::Run(Binary() + " replay config/tracked_hand.yaml " + log + " --duration 2.0 --out " + out);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(r.output.find('\r'), std::string::npos) << "no progress bar when stdout is not a terminal";
    uint64_t h = 0;
    for (const char* f : {"trajectory.csv", "fingertips.csv", "tracker.csv", "summary.json"}) {
      const std::string text = test::ReadFile(out + "/" + f);
      ASSERT_FALSE(text.empty()) << f;
      h = h * 31 + test::Hash(text);
    }
    hashes[run] = h;
    summary[run] = test::ReadFile(out + "/summary.json");
  }
  EXPECT_EQ(hashes[0], hashes[1]) << "replays differ";
  EXPECT_NE(summary[0].find("\"lifted\":true"), std::string::npos) << summary[0];
  EXPECT_NE(summary[0].find("\"parse_errors\":0"), std::string::npos) << summary[0];
  // about 200 of the 291 datagrams arrived within the first 2 s (their recorded arrival times decide)
  const size_t at = summary[0].find("\"datagrams_applied\":");
  ASSERT_NE(at, std::string::npos);
  const int applied = std::atoi(summary[0].c_str() + at + 20);
  EXPECT_GE(applied, 190);
  EXPECT_LE(applied, 210);
  EXPECT_NE(summary[0].find("\"rejected_steps\":0"), std::string::npos) << summary[0];
}

// replay --out writes contacts.csv: one line per step and body pair, so that a whole
// hand's grasp gives each segment's force on the box
TEST(SessionsEndToEnd, WholeHandReplayWritesEachSegmentsForceOnTheBox) {
  const std::string out = test::TempDir("whole_hand_replay");
  const std::string src = GRASPSIM_SOURCE_DIR;
  const test::Result r = test::Run(Binary() + " replay " + src + "/config/whole_hand_power_grasp.yaml " + src +
                                   "/assets/whole_hand_power_grasp.lcmlog --duration 2.5 --quiet --out " + out);
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream f(out + "/contacts.csv");
  std::string line;
  ASSERT_TRUE(std::getline(f, line));
  EXPECT_EQ(line, "step,t_s,body_a,body_b,contacts,stick,slip,separating,fn_N,ft_N,penetration_before_m,"
                  "penetration_after_m");
  std::map<std::string, double> most;  // the largest normal force of each body on the box
  while (std::getline(f, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    ASSERT_EQ(cells.size(), 12u) << line;
    const std::string other = cells[2] == "box" ? cells[3] : cells[3] == "box" ? cells[2] : "";
    if (!other.empty()) most[other] = std::max(most[other], std::stod(cells[8]));
  }
  // the thumb and the four fingers' two outer phalanges all press on the box by 2.5 s
  for (const char* finger : {"thumb", "index", "middle", "ring", "little"})
    for (const char* segment : {"_outer", "_middle"}) {
      const std::string name = std::string(finger) + segment;
      EXPECT_GT(most[name], 0.01) << name;
    }
  EXPECT_GT(most["table"], 0.0);
  // trajectory.csv follows every moving body: the box, the palm and the phalanges
  // the fingers carry
  std::ifstream traj(out + "/trajectory.csv");
  std::string header;
  ASSERT_TRUE(std::getline(traj, header));
  for (const char* column : {",box_z_m,", ",palm_z_m,", ",index_inner_x_m,", ",thumb_outer_qw,", ",little_middle_y_m,"})
    EXPECT_NE(header.find(column), std::string::npos) << column << " in " << header;
}

// a session of the other hand (a right glove's log in a scene with `side: left`) drives
// nothing: replay says so, names the key to change, and still writes its outputs
TEST(SessionsEndToEnd, ReplayOfTheOtherHandSaysNothingWasDriven) {
  const std::string dir = test::TempDir("e2e_other_side");
  const std::string src = GRASPSIM_SOURCE_DIR;
  std::string scene = test::ReadFile(src + "/config/whole_hand_power_grasp.yaml");
  const size_t at = scene.find("side: right");
  ASSERT_NE(at, std::string::npos);
  scene.replace(at, 11, "side: left");
  std::ofstream(dir + "/left.yaml") << scene;
  const std::string log = src + "/assets/whole_hand_power_grasp.lcmlog";
  test::Result r = test::Run(Binary() + " replay " + dir + "/left.yaml " + log + " --quiet --out " + dir + "/out");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("good datagrams (carrying hand 0 (left), tracked): 0 of"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("carry hand 0 as a right hand, where the scene's hand has `side: left` (set `side: right`"),
            std::string::npos)
      << r.output;
  const std::string summary = test::ReadFile(dir + "/out/summary.json");
  EXPECT_NE(summary.find("\"good_datagrams\":0,"), std::string::npos) << summary;
  EXPECT_EQ(summary.find("\"other_side_datagrams\":0"), std::string::npos) << summary;
  // cut short by --duration, the session is not judged whole: the tally alone
  r = test::Run(Binary() + " replay " + dir + "/left.yaml " + log + " --duration 0.3 --quiet");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("good datagrams (carrying hand 0 (left), tracked): 0 of"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("never driven"), std::string::npos) << r.output;
  // the right scene: every datagram drives it
  r = test::Run(Binary() + " replay " + src + "/config/whole_hand_power_grasp.yaml " + log + " --duration 0.3 --json");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("\"missing_datagrams\":0,\"other_side_datagrams\":0"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("\"good_datagrams\":0,"), std::string::npos) << r.output;
}

TEST(SessionsEndToEnd, ReplayRefusesBadInputWithAMessage) {
  const std::string dir = test::TempDir("e2e_bad");
  test::Result r = test::Run(Binary() + " replay " + dir + "/missing.lcmlog");
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.output.find("missing.lcmlog"), std::string::npos) << r.output;
  {
    std::ofstream f(dir + "/text.lcmlog");
    f << "this is not an LCM log\n";
  }
  r = test::Run(Binary() + " replay " + dir + "/text.lcmlog");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("text.lcmlog: byte 0: no LCM event starts here"), std::string::npos) << r.output;
  // a scene without a tracker section
  r = test::Run(Binary() + " replay config/paper_box_grasp.yaml " + std::string(GRASPSIM_SOURCE_DIR) +
                "/assets/demo_session.lcmlog");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("tracker"), std::string::npos) << r.output;
  // send without a source
  r = test::Run(Binary() + " send --port 9");
  EXPECT_EQ(r.code, 2) << r.output;
}

}  // namespace
}  // namespace gs::tracking
