// graspsim live next to a misbehaving tracker. One live run with an allow list
// (127.0.0.1) goes through every fault in turn, driven by `graspsim send` (the
// tracker) and a small fault injector (garbage and floods, from the allowed
// address and from 127.0.0.2):
//   tracker at 100 Hz -> stops -> restarts at 50 Hz -> garbage among good frames
//   -> a flood of 20,000 datagrams/s -> a flood from outside the allow list
//   -> good data only, to the end (the tracker runs until live has ended).
// live must keep stepping, report each fault as it happens, and end with the
// tracker ok.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <csignal>
#include <random>
#include <thread>

#include "test_util.h"

namespace gs::tracking {
namespace {

using Clock = std::chrono::steady_clock;

// Sends datagrams to 127.0.0.1:port from a socket bound to `source` (any
// 127.x.y.z address is local on Linux), paced in 1 ms bursts.
class FaultInjector {
 public:
  FaultInjector(const std::string& source, int port) {
    fd_ = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in src{};
    src.sin_family = AF_INET;
    inet_pton(AF_INET, source.c_str(), &src.sin_addr);
    ok_ = fd_ >= 0 && bind(fd_, reinterpret_cast<sockaddr*>(&src), sizeof(src)) == 0;
    dst_.sin_family = AF_INET;
    dst_.sin_port = htons(static_cast<uint16_t>(port));
    inet_pton(AF_INET, "127.0.0.1", &dst_.sin_addr);
  }
  ~FaultInjector() {
    if (fd_ >= 0) close(fd_);
  }
  bool ok() const { return ok_; }
  /// `rate` datagrams per second for `seconds`; returns how many were sent.
  uint64_t Send(const std::string& payload, double rate, double seconds) {
    const auto start = Clock::now();
    uint64_t sent = 0;
    for (;;) {
      const double t = std::chrono::duration<double>(Clock::now() - start).count();
      if (t >= seconds) break;
      for (const uint64_t due = static_cast<uint64_t>(rate * t); sent < due; ++sent)
        sendto(fd_, payload.data(), payload.size(), 0, reinterpret_cast<const sockaddr*>(&dst_), sizeof(dst_));
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return sent;
  }

 private:
  int fd_ = -1;
  bool ok_ = false;
  sockaddr_in dst_{};
};

size_t Find(const std::string& text, const std::string& what, size_t from = 0) { return text.find(what, from); }

double JsonNumber(const std::string& text, const std::string& key) {
  const size_t at = text.find("\"" + key + "\":");
  if (at == std::string::npos) return NAN;
  return std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

TEST(LiveFaults, ReportsEachTrackerFaultAndRecovers) {
  const int port = test::FreeUdpPort();
  const std::string scene = std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml";
  const std::string send = test::Binary() + " send --synthetic --port " + std::to_string(port);
  test::Background live(test::Binary() + " live " + scene + " --port " + std::to_string(port) +
                        " --allow 127.0.0.1 --duration 11.5 --publish-rate 0");
  ASSERT_NE(live.ReadLine().find("live: scene"), std::string::npos);
  ASSERT_TRUE(live.ReadUntil("live: listening on UDP port " + std::to_string(port))) << live.Wait().output;
  const auto t0 = Clock::now();
  auto at = [&](double s) { std::this_thread::sleep_until(t0 + std::chrono::duration<double>(s)); };

  // 0 - 2.9 s: the tracker at 100 Hz (291 frames); then it stops for a second
  test::Result first = test::Run(send + " --rate 100");
  ASSERT_EQ(first.code, 0) << first.output;
  at(4.0);
  // from 4 s: it restarts at 40 Hz and sends until live has ended (passes of the 2.9 s session
  // enough to outlast live's 11.5 s whenever live's clock started; stopped below). The faults
  // happen meanwhile.
  const std::string tracker_log = ::testing::TempDir() + "live_faults_tracker.log";
  test::Child tracker({test::Binary(), "send", "--synthetic", "--port", std::to_string(port), "--rate", "40", "--loop",
                       "20"},
                      tracker_log);
  ASSERT_TRUE(tracker.started());
  FaultInjector allowed("127.0.0.1", port), stranger("127.0.0.2", port);
  ASSERT_TRUE(allowed.ok() && stranger.ok());
  at(6.5);
  allowed.Send("fr 7\r\n6d 2 [0 1.000][1 2 3 0 0 0][1 0 0 0 1 0 0 0 1] [1 1.000][4 5\r\n", 30, 0.8);  // cut short
  at(8.0);
  [[maybe_unused]] const uint64_t flood = allowed.Send(std::string(200, 'x'), 20000, 0.6);  // read unless sanitized
  at(9.5);
  const uint64_t strangers = stranger.Send("fr 1\n", 20000, 0.6);
  const test::Result r = live.Wait();
  tracker.Signal(SIGINT);
  tracker.Wait();
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string& out = r.output;

  // each fault reported, in order
  size_t p = 0;
  for (const char* event : {"tracker at ", "tracker silent", "tracker back", "tracker rate changed from ",
                            "garbage:", "flood:", "flood over",
                            "rejecting datagrams from 127.0.0.2", "no more datagrams from senders outside"}) {
    const size_t q = Find(out, event, p);
    ASSERT_NE(q, std::string::npos) << "no '" << event << "' after position " << p << " in:\n" << out;
    p = q;
  }
  // the garbage's end may share a window with the flood's start (a slow receiver drains late)
  EXPECT_NE(Find(out, "datagrams parse cleanly again", Find(out, "garbage:")), std::string::npos) << out;
  const std::string json = out.substr(out.rfind("{\"live\""));
  EXPECT_EQ(JsonNumber(json, "silences"), 1) << out;
  EXPECT_EQ(JsonNumber(json, "recoveries"), 1) << out;
  EXPECT_EQ(JsonNumber(json, "rate_changes"), 1) << out;
  EXPECT_GE(JsonNumber(json, "floods"), 1) << out;
  EXPECT_EQ(JsonNumber(json, "rejected_bursts"), 1) << out;
  EXPECT_EQ(JsonNumber(json, "rejected_senders"), static_cast<double>(strangers)) << out;
  EXPECT_NE(json.find("\"tracker_state\":\"ok\""), std::string::npos) << out;
#ifndef GRASPSIM_SANITIZED
  // the datagrams from the allowed address were taken in (the flood at least); a sanitized
  // receiver parses too slowly for 20,000/s and the kernel drops some (counted, not asserted)
  EXPECT_GE(JsonNumber(json, "datagrams"), 0.9 * static_cast<double>(flood)) << out;
#endif
  // the simulation kept stepping through it all (a sanity bound; live's figures are in its summary).
  // Sanitized builds step 5-15x slower and share the machine with the test's sender: there the
  // bound only says the simulation never stalled (it ran 384 Hz under TSan on a loaded 2-core box)
#ifndef GRASPSIM_SANITIZED
  EXPECT_GT(JsonNumber(json, "sim_rate_hz"), 500.0) << out;
#else
  EXPECT_GT(JsonNumber(json, "sim_rate_hz"), 100.0) << out;
#endif
  std::printf("%s\n", json.c_str());
}

// Datagrams that arrive but do not carry what the scene needs are not a healthy
// tracker: one live run (hand 0, tracked_hand_light.yaml) gets random bytes at 100 Hz,
// then real DTrack frames (fr, ts, 6d) without a gl hand at 100 Hz, then the synthetic
// hand. The first two give their events and no "tracker at ... Hz"; the good rate
// appears only with the hand.
TEST(LiveFaults, DatagramsWithoutWhatTheSceneNeedsAreNotAGoodTracker) {
  const int port = test::FreeUdpPort();
  const std::string scene = std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml";
  test::Background live(test::Binary() + " live " + scene + " --port " + std::to_string(port) +
                        " --allow 127.0.0.1 --duration 8 --publish-rate 0");
  ASSERT_TRUE(live.ReadUntil("live: listening on UDP port " + std::to_string(port))) << live.Wait().output;
  FaultInjector tracker("127.0.0.1", port);
  ASSERT_TRUE(tracker.ok());
  // 0 - 1.5 s: random bytes (fixed seed; no NUL, so every byte is looked at)
  std::mt19937 rng(22);
  std::string noise(300, ' ');
  for (char& ch : noise) ch = static_cast<char>(1 + rng() % 255);
  const uint64_t random_sent = tracker.Send(noise, 100, 1.5);
  // 1.5 - 3 s: DTrack frames with a 6d body and no hand
  const uint64_t handless_sent = tracker.Send(
      "fr 12\r\nts 1.000000\r\n6dcal 1\r\n6d 1 [0 1.000][10.0 20.0 30.0][1 0 0 0 1 0 0 0 1]\r\n", 100, 1.5);
  // 3 - 5.9 s: the synthetic hand
  const test::Result send = test::Run(test::Binary() + " send --synthetic --port " + std::to_string(port));
  ASSERT_EQ(send.code, 0) << send.output;
  const test::Result r = live.Wait();
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string& out = r.output;
  const size_t not_dtrack = Find(out, "datagrams are not DTrack: ");
  const size_t absent = Find(out, "hand 0 absent from 100 % of datagrams in the last ");
  const size_t rate = Find(out, "tracker at ");
  ASSERT_NE(not_dtrack, std::string::npos) << out;
  ASSERT_NE(absent, std::string::npos) << out;
  ASSERT_NE(rate, std::string::npos) << "the synthetic hand gives a good rate:\n" << out;
  // in that order: no good rate while the datagrams lacked the hand
  EXPECT_LT(not_dtrack, absent) << out;
  EXPECT_LT(absent, rate) << out;
  EXPECT_NE(Find(out, "hand 0 tracked again", absent), std::string::npos) << out;
  const std::string json = out.substr(out.rfind("{\"live\""));
  EXPECT_EQ(JsonNumber(json, "not_dtrack_datagrams"), static_cast<double>(random_sent)) << out;
  EXPECT_EQ(JsonNumber(json, "missing_datagrams"), static_cast<double>(handless_sent)) << out;
  EXPECT_EQ(JsonNumber(json, "good_datagrams"), 291) << out;
  EXPECT_EQ(JsonNumber(json, "datagrams"), static_cast<double>(random_sent + handless_sent + 291)) << out;
  EXPECT_EQ(JsonNumber(json, "not_dtrack_bursts"), 1) << out;
  EXPECT_EQ(JsonNumber(json, "missing_bursts"), 1) << out;
  // the first good-rate figure may take in a moment of the switch from hand-less frames
  // to the hand, on a loaded machine (under TSan: 78.9 Hz, then a change to 100.2 Hz)
  EXPECT_LE(JsonNumber(json, "rate_changes"), 1) << out;
  // the good rate is the hand's 100 Hz, over the good datagrams only
  EXPECT_NEAR(JsonNumber(json, "good_hz"), 100.0, 10.0) << out;
}

// Random bytes alone: all datagrams arrive at about 100 Hz, none is good; the summary
// says so and the state is not "ok".
TEST(LiveFaults, RandomBytesGiveNoGoodRate) {
  const int port = test::FreeUdpPort();
  const std::string scene = std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml";
  test::Background live(test::Binary() + " live " + scene + " --port " + std::to_string(port) +
                        " --duration 3 --publish-rate 0");
  ASSERT_TRUE(live.ReadUntil("live: listening on UDP port " + std::to_string(port))) << live.Wait().output;
  FaultInjector tracker("127.0.0.1", port);
  ASSERT_TRUE(tracker.ok());
  std::mt19937 rng(7);
  std::string noise(200, ' ');
  for (char& ch : noise) ch = static_cast<char>(1 + rng() % 255);
  const uint64_t sent = tracker.Send(noise, 100, 4.0);  // past live's end: the stream never stops while it listens
  const test::Result r = live.Wait();
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(Find(r.output, "datagrams are not DTrack: "), std::string::npos) << r.output;
  EXPECT_EQ(Find(r.output, "tracker at "), std::string::npos) << r.output;
  const std::string json = r.output.substr(r.output.rfind("{\"live\""));
  EXPECT_GT(JsonNumber(json, "datagrams"), 100) << r.output;
  EXPECT_LE(JsonNumber(json, "datagrams"), static_cast<double>(sent)) << r.output;
  EXPECT_EQ(JsonNumber(json, "good_datagrams"), 0) << r.output;
  EXPECT_EQ(JsonNumber(json, "good_hz"), 0) << r.output;
  EXPECT_NE(json.find("\"tracker_state\":\"not-dtrack\""), std::string::npos) << r.output;
}

}  // namespace
}  // namespace gs::tracking
