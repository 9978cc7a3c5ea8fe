// Recordings are irreplaceable: `graspsim record` under a flood writes every
// datagram that reached its socket and counts the kernel's drops separately; a
// recording killed with SIGKILL leaves a log readable up to its last whole
// event, which `graspsim replay` accepts; SIGINT and SIGTERM end record, replay
// and live cleanly with their files complete.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <thread>

#include "test_util.h"
#include "tracking/session_log.h"
#include "tracking/udp_receiver.h"

namespace gs::tracking {
namespace {

using Clock = std::chrono::steady_clock;

/// Waits until `path` holds `text` (a child's log), at most `seconds`.
bool WaitForText(const std::string& path, const std::string& text, double seconds) {
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (Clock::now() < end) {
    if (test::ReadFile(path).find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

/// The number right after the first `key` in `text` that a digit follows (-1 if none).
long long NumberAfter(const std::string& text, const std::string& key) {
  for (size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
    const char c = text[at + key.size()];
    if (c >= '0' && c <= '9') return std::atoll(text.c_str() + at + key.size());
  }
  return -1;
}

struct LogCount {
  uint64_t datagrams = 0;
  bool contiguous = true;  // sequence numbers 0, 1, 2, ...
  SessionReadStats stats;
  std::string error;
};

LogCount CountLog(const std::string& path) {
  LogCount c;
  SessionReader r;
  if (!r.Open(path, &c.error)) return c;
  RecordedDatagram d;
  while (r.Next(&d)) {
    if (d.sequence != static_cast<int64_t>(c.datagrams)) c.contiguous = false;
    ++c.datagrams;
  }
  c.stats = r.stats();
  c.error = r.error();
  return c;
}

/// Waits until the log at `path` holds `n` datagrams, at most `seconds`; returns how many it holds.
uint64_t WaitForLogDatagrams(const std::string& path, uint64_t n, double seconds) {
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  uint64_t seen = CountLog(path).datagrams;
  while (seen < n && Clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    seen = CountLog(path).datagrams;
  }
  return seen;
}

/// Waits until the log at `path` has stopped growing for `quiet_ms` (the recorder has
/// drained its socket), at most `seconds`.
void WaitForLogToSettle(const std::string& path, int quiet_ms, double seconds) {
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  uint64_t last = CountLog(path).datagrams;
  auto since = Clock::now();
  while (Clock::now() < end && Clock::now() - since < std::chrono::milliseconds(quiet_ms)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const uint64_t now = CountLog(path).datagrams;
    if (now != last) {
      last = now;
      since = Clock::now();
    }
  }
}

std::string Packet() { return test::ReadFile(std::string(GRASPSIM_TEST_DATA) + "/dtrack/d_ts2_left_hand_5.txt"); }

// with a large buffer nothing is dropped on an idle machine; with the smallest one the kernel drops some:
// either way what was written plus what the kernel dropped is what was sent
class RecordFlood : public ::testing::TestWithParam<int> {};

TEST_P(RecordFlood, WritesEveryDatagramThatReachedTheSocketAndCountsKernelDrops) {
  const std::string dir = test::TempDir("flood" + std::to_string(GetParam()));
  const std::string log = dir + "/flood.lcmlog", out = dir + "/record.txt";
  const int port = test::FreeUdpPort();
  test::Child record({test::Binary(), "record", "--quiet", "--port", std::to_string(port), "-o", log, "--rcvbuf",
                      std::to_string(GetParam())},
                     out);
  ASSERT_TRUE(record.started());
  ASSERT_TRUE(WaitForText(out, "record: listening", 30)) << test::ReadFile(out);

  // 20,000 five-finger hand datagrams per second for 2 s (GRASPSIM_FLOOD_SECONDS=10 for the full
  // length), paced in 1 ms batches of 20
  const char* env = std::getenv("GRASPSIM_FLOOD_SECONDS");
  const int seconds = env ? std::max(1, std::atoi(env)) : 2;
  const std::string packet = Packet();
  ASSERT_GT(packet.size(), 200u);
  UdpSender tx;
  std::string error;
  ASSERT_TRUE(tx.Open("127.0.0.1", port, &error)) << error;
  uint64_t sent = 0;
  const auto t0 = Clock::now();
  for (int ms = 0; ms < 1000 * seconds; ++ms) {
    for (int i = 0; i < 20; ++i) sent += tx.Send(packet.data(), packet.size()) ? 1 : 0;
    std::this_thread::sleep_until(t0 + std::chrono::milliseconds(ms + 1));
  }
  ASSERT_GE(sent, 19950u * seconds);
  // the recorder drains its socket: its log stops growing (a fixed wait was short on a loaded machine)
  WaitForLogToSettle(log, 500, 30);
  record.Signal(SIGTERM);
  ASSERT_EQ(record.Wait(), 0) << test::ReadFile(out);

  const std::string text = test::ReadFile(out);
  const long long written = NumberAfter(text, "record: ");
  const long long received = NumberAfter(text, "socket received ");
  const long long dropped = NumberAfter(text, "the kernel dropped ");
  ASSERT_GE(written, 0) << text;
  ASSERT_GE(received, 0) << text;
  ASSERT_GE(dropped, 0) << text;
  EXPECT_EQ(written, received) << "every datagram that reached the socket is written\n" << text;
  EXPECT_EQ(static_cast<uint64_t>(received + dropped), sent) << "loopback loses nothing else\n" << text;
  EXPECT_NE(text.find("0 write errors"), std::string::npos) << text;
  const LogCount c = CountLog(log);
  EXPECT_TRUE(c.error.empty()) << c.error;
  EXPECT_EQ(c.datagrams, static_cast<uint64_t>(written));
  EXPECT_TRUE(c.contiguous);
  EXPECT_EQ(c.stats.trailing_bytes, 0u);
  std::printf("flood with a %d-byte buffer: %llu sent, %lld written, %lld dropped by the kernel\n", GetParam(),
              static_cast<unsigned long long>(sent), written, dropped);
  std::filesystem::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Buffers, RecordFlood, ::testing::Values(16 << 20, 4096),
                         [](const ::testing::TestParamInfo<int>& i) { return "rcvbuf" + std::to_string(i.param); });

TEST(RecordReliability, KilledRecordingIsReadableToItsLastWholeEventAndReplays) {
  const std::string dir = test::TempDir("killed");
  const std::string log = dir + "/killed.lcmlog", out = dir + "/record.txt";
  const int port = test::FreeUdpPort();
  test::Child record({test::Binary(), "record", "--quiet", "--port", std::to_string(port), "-o", log}, out);
  ASSERT_TRUE(WaitForText(out, "record: listening", 30)) << test::ReadFile(out);
  // the synthetic hand at 100 Hz; the recorder dies once 100 datagrams are on disk (read
  // from the log as it grows), without a chance to close its log
  test::Background send(test::Binary() + " send --synthetic --port " + std::to_string(port));
  uint64_t seen = 0;
  for (int i = 0; i < 3000 && seen < 100; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    seen = CountLog(log).datagrams;
  }
  record.Signal(SIGKILL);
  EXPECT_EQ(record.Wait(), -1);
  ASSERT_EQ(send.Wait().code, 0);
  ASSERT_GE(seen, 100u) << "the recording did not reach 100 datagrams in 30 s";

  // what was on disk before the kill is all there; flushed every 50 ms, so at most the
  // datagrams of the last few tens of milliseconds (at 100 Hz: a handful) are lost
  const LogCount c = CountLog(log);
  EXPECT_TRUE(c.error.empty()) << c.error;
  EXPECT_GE(c.datagrams, seen);
  EXPECT_LE(c.datagrams, seen + 30);
  EXPECT_TRUE(c.contiguous);
  const test::Result r = test::Run(test::Binary() + " replay config/tracked_hand.yaml " + log +
                                   " --duration 0.5 --out " + dir + "/replay");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_FALSE(test::ReadFile(dir + "/replay/summary.json").empty());

  // a log cut in the middle of an event (as a kill between two writes of one event leaves
  // it): cut 17 bytes into its last whole event (the kill above may itself have left a
  // torn event at the end, whose bytes are not counted as an event)
  const std::string whole = test::ReadFile(log);
  ASSERT_GT(whole.size(), c.stats.trailing_bytes + 17);
  const std::string torn_path = dir + "/torn.lcmlog";
  {
    std::ofstream f(torn_path, std::ios::binary);
    f << whole.substr(0, whole.size() - c.stats.trailing_bytes - 17);
  }
  const LogCount t = CountLog(torn_path);
  EXPECT_TRUE(t.error.empty()) << t.error;
  EXPECT_EQ(t.datagrams + 1, c.datagrams) << "the torn last event is ignored, the others read";
  EXPECT_GT(t.stats.trailing_bytes, 0u);
  const test::Result rt =
      test::Run(test::Binary() + " replay config/tracked_hand.yaml " + torn_path + " --duration 0.5");
  EXPECT_EQ(rt.code, 0) << rt.output;
  EXPECT_NE(rt.output.find("incomplete event"), std::string::npos) << rt.output;
  std::filesystem::remove_all(dir);
}

// a log of two datagrams, with its bytes then damaged at chosen places
class DamagedLog : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::TempDir("damaged");
    SessionWriter w;
    std::string error;
    ASSERT_TRUE(w.Open(dir_ + "/ok.lcmlog", &error)) << error;
    const std::string packet = Packet();
    for (int k = 0; k < 2; ++k) {
      Datagram d;
      d.data = packet.data();
      d.size = packet.size();
      d.sequence = static_cast<uint64_t>(k);
      d.monotonic_ns = 1000000 * k;
      std::snprintf(d.source, sizeof(d.source), "127.0.0.1:5000");
      ASSERT_TRUE(w.Write(d));
    }
    w.Close();
    bytes_ = test::ReadFile(dir_ + "/ok.lcmlog");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  // writes the log with `n` big-endian bytes of `value` at `offset`, and reads it
  LogCount With(size_t offset, uint64_t value, int n) {
    std::string b = bytes_;
    for (int k = 0; k < n; ++k) b[offset + k] = static_cast<char>(value >> (8 * (n - 1 - k)));
    const std::string path = dir_ + "/bad.lcmlog";
    std::ofstream(path, std::ios::binary) << b;
    return CountLog(path);
  }
  // event 1: 28-byte header, the 10-byte channel, then the message: type hash, three int64, source length
  static constexpr size_t kDataLen = 24, kMessage = 38, kSourceLen = 38 + 32;
  std::string dir_, bytes_;
};

TEST_F(DamagedLog, IntactReadsBoth) { EXPECT_EQ(CountLog(dir_ + "/ok.lcmlog").datagrams, 2u); }

TEST_F(DamagedLog, HugeDataLengthIsACutShortLogNotAnAllocation) {
  const LogCount c = With(kDataLen, 0x7fffffff, 4);
  EXPECT_EQ(c.datagrams, 0u);
  EXPECT_EQ(c.stats.trailing_bytes, bytes_.size());
}

TEST_F(DamagedLog, NegativeDataLengthIsRefusedWithItsOffset) {
  const LogCount c = With(kDataLen, 0xffffffff, 4);
  EXPECT_NE(c.error.find("byte 0: event with a channel name of 10 bytes and -1 bytes"), std::string::npos) << c.error;
}

TEST_F(DamagedLog, BadSourceLengthsAreRefused) {
  for (uint64_t len : {0ull, 0xffffffffull, 0x7fffffffull}) {
    const LogCount c = With(kSourceLen, len, 4);
    EXPECT_NE(c.error.find("event 1 on DTRACK_RAW has a source address of a bad length"), std::string::npos)
        << len << ": " << c.error;
  }
}

TEST_F(DamagedLog, OtherTypeIsRefused) {
  const LogCount c = With(kMessage, 0x0123456789abcdefull, 8);
  EXPECT_NE(c.error.find("is not a graspsim.dtrack_datagram_t"), std::string::npos) << c.error;
}

TEST_F(DamagedLog, GarbageBetweenEventsNamesItsOffset) {
  const size_t second = bytes_.size() / 2;  // both events have the same length
  const LogCount c = With(second, 0xdeadbeef, 4);
  EXPECT_EQ(c.datagrams, 1u);
  EXPECT_NE(c.error.find("byte " + std::to_string(second) + ": no LCM event starts here"), std::string::npos) << c.error;
}

TEST(Signals, RecordEndsCleanlyOnSigint) {
  const std::string dir = test::TempDir("sig_record");
  const std::string log = dir + "/s.lcmlog", out = dir + "/record.txt";
  const int port = test::FreeUdpPort();
  test::Child record({test::Binary(), "record", "--quiet", "--port", std::to_string(port), "-o", log}, out);
  ASSERT_TRUE(WaitForText(out, "record: listening", 30)) << test::ReadFile(out);
  const std::string packet = Packet();
  UdpSender tx;
  std::string error;
  ASSERT_TRUE(tx.Open("127.0.0.1", port, &error)) << error;
  for (int i = 0; i < 50; ++i) {
    tx.Send(packet.data(), packet.size());
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  // all 50 on disk before the signal (record then has nothing left to drain)
  EXPECT_EQ(WaitForLogDatagrams(log, 50, 30), 50u);
  record.Signal(SIGINT);
  ASSERT_EQ(record.Wait(), 0) << test::ReadFile(out);
  EXPECT_NE(test::ReadFile(out).find("record: 50 datagrams"), std::string::npos) << test::ReadFile(out);
  const LogCount c = CountLog(log);
  EXPECT_EQ(c.datagrams, 50u) << c.error;
  EXPECT_EQ(c.stats.trailing_bytes, 0u);
  std::filesystem::remove_all(dir);
}

TEST(Signals, ReplayStopsOnSigtermAndWritesItsOutputs) {
  const std::string dir = test::TempDir("sig_replay");
  const std::string out = dir + "/replay.txt";
  test::Child replay({test::Binary(), "replay", "--realtime", "config/tracked_hand.yaml",
                      std::string(GRASPSIM_TEST_DATA) + "/../../assets/demo_session.lcmlog", "--out", dir + "/out"},
                     out);
  ASSERT_TRUE(WaitForText(out, "simulating", 60)) << test::ReadFile(out);
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  replay.Signal(SIGTERM);
  EXPECT_EQ(replay.Wait(), 130) << test::ReadFile(out);  // interrupted, like a shell's 128 + SIGINT
  const std::string text = test::ReadFile(out);
  EXPECT_NE(text.find("replay: interrupted at t="), std::string::npos) << text;
  const std::string summary = test::ReadFile(dir + "/out/summary.json");
  ASSERT_FALSE(summary.empty()) << text;
  EXPECT_EQ(summary.back(), '\n');
  EXPECT_EQ(summary[summary.size() - 2], '}');
  EXPECT_GT(NumberAfter(summary, "\"steps\":"), 0);
  const std::string traj = test::ReadFile(dir + "/out/trajectory.csv");
  EXPECT_GT(std::count(traj.begin(), traj.end(), '\n'), 10);
  std::filesystem::remove_all(dir);
}

TEST(Signals, LiveEndsCleanlyOnSigtermWithItsSummary) {
  const std::string dir = test::TempDir("sig_live");
  const std::string out = dir + "/live.txt";
  const int port = test::FreeUdpPort();
  test::Child live({test::Binary(), "live", std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml",
                    "--port", std::to_string(port), "--publish-rate", "0"},
                   out);
  ASSERT_TRUE(WaitForText(out, "live: listening", 60)) << test::ReadFile(out);
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  live.Signal(SIGTERM);
  EXPECT_EQ(live.Wait(), 0) << test::ReadFile(out);
  const std::string text = test::ReadFile(out);
  EXPECT_NE(text.find("{\"live\":true"), std::string::npos) << text;
  EXPECT_GT(NumberAfter(text, "\"steps\":"), 0) << text;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gs::tracking
