// graspsim live receives graspsim send on loopback: the tracker rate received
// equals the rate sent, no parse errors, the 1 kHz simulation rate holds, and
// poses and contacts are published on LCM (here into an LCM log file URL).
#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <thread>

#include "graspsim/contacts_t.hpp"
#include "graspsim/poses_t.hpp"
#include "test_util.h"
#include "tracking/session_log.h"

namespace gs::tracking {
namespace {

double JsonNumber(const std::string& text, const std::string& key) {
  const size_t at = text.find("\"" + key + "\":");
  if (at == std::string::npos) return NAN;
  return std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

TEST(Live, ReceivesSendOnLoopbackAtTheRateSentAndHoldsItsRate) {
  const std::string dir = test::TempDir("live");
  const int port = test::FreeUdpPort();
  const std::string scene = std::string(GRASPSIM_TEST_DATA) + "/tracking/tracked_hand_light.yaml";
  test::Background live(test::Binary() + " live " + scene + " --port " + std::to_string(port) +
                        " --duration 6 --publish-rate 50 --lcm-url 'file://" + dir + "/live.lcmlog?mode=w'");
  ASSERT_NE(live.ReadLine().find("live: scene"), std::string::npos);
  // the socket is open once live says so (start-up takes a while under sanitizers)
  ASSERT_TRUE(live.ReadUntil("live: listening on UDP port " + std::to_string(port))) << live.Wait().output;
  const test::Result send =
      test::Run(test::Binary() + " send --synthetic --rate 100 --port " + std::to_string(port) + " --delay 0");
  ASSERT_EQ(send.code, 0) << send.output;
  const test::Result r = live.Wait();
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string json = r.output.substr(r.output.rfind("{\"live\""));
  EXPECT_EQ(JsonNumber(json, "datagrams"), 291) << r.output;
  // the rate received is the rate sent, as the sender measured it on its own clock (a
  // sender slowed by a loaded machine slows both); the receiver stamps each datagram when
  // its thread reads it, so a late first or last read moves the span: 2 % is 58 ms of it
  const size_t hz_at = send.output.rfind(" Hz)");
  ASSERT_NE(hz_at, std::string::npos) << send.output;
  const double sent_hz = std::strtod(send.output.c_str() + send.output.rfind('(', hz_at) + 1, nullptr);
  EXPECT_NEAR(sent_hz, 100.0, 5.0) << send.output;
  EXPECT_NEAR(JsonNumber(json, "tracker_hz"), sent_hz, 0.02 * sent_hz) << send.output << r.output;
  EXPECT_EQ(JsonNumber(json, "parse_errors"), 0) << r.output;
  // The loop paces itself at the scene's 1 kHz. This is a sanity bound, not a timing figure
  // (`graspsim bench tracking` and live's status report the rate and overruns): a loop that
  // lost its pacing, or ran unpaced, would land far outside it even on a loaded machine.
  EXPECT_LT(JsonNumber(json, "sim_rate_hz"), 1005.0) << r.output;
  // every slot of the schedule is accounted for: run, or given up when the loop fell more
  // than 50 ms behind (checked after each step: it may end 50 ms plus its longest step behind).
  // The run's wall time ends with the simulation thread's last step, whose skipped slots
  // (a sanitized loop runs behind) reach that step's end.
  const double slots = 1000.0 * JsonNumber(json, "wall_s");
  const double accounted = JsonNumber(json, "steps") + JsonNumber(json, "skipped_steps");
  EXPECT_LE(accounted, slots + 2) << r.output;
  EXPECT_GE(accounted, slots - 52 - JsonNumber(json, "step_max_ms")) << r.output;
#ifndef GRASPSIM_SANITIZED
  EXPECT_GT(JsonNumber(json, "sim_rate_hz"), 500.0) << r.output;
#else
  // under ASan the grasp's steps take about 6 ms each (0.5 ms in release): the loop gives
  // those slots up, as it should, and its rate says only how slow the instrumented build is
#endif
  EXPECT_NE(json.find("\"lcm_ok\":true"), std::string::npos) << r.output;
  // the step budget (default 0.8 of a timestep): its stops are among the unconverged steps
  EXPECT_LE(JsonNumber(json, "budget_stops"), JsonNumber(json, "unconverged_steps")) << r.output;
  EXPECT_LE(JsonNumber(json, "unconverged_steps"), JsonNumber(json, "steps")) << r.output;
  EXPECT_TRUE(std::isfinite(JsonNumber(json, "residual_max"))) << r.output;
  // steps whose pairs carried their contacts after steps past the budget: at most two in three
  EXPECT_GE(JsonNumber(json, "carried_contact_steps"), 0) << r.output;
  EXPECT_LE(3 * JsonNumber(json, "carried_contact_steps"), 2 * JsonNumber(json, "steps") + 2) << r.output;
  EXPECT_EQ(JsonNumber(json, "lead_steps"), 1) << r.output;  // a step may begin one timestep early (session/pacing.h)

  // what was published: poses and contacts at about 50 Hz each
  lcm::LogFile log(dir + "/live.lcmlog", "r");
  ASSERT_TRUE(log.good());
  int poses = 0, contacts = 0, contacts_with_force = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == kPosesChannel) {
      graspsim::poses_t m;
      ASSERT_GE(m.decode(ev->data, 0, ev->datalen), 0);
      ASSERT_EQ(m.num_bodies, 5);
      ASSERT_EQ(m.num_fingertips, 3);
      EXPECT_EQ(m.fingertips[0].name, "thumb");
      EXPECT_EQ(m.fingertips[0].body, "thumb_tip");
      ++poses;
    } else if (ev->channel == kContactsChannel) {
      graspsim::contacts_t m;
      ASSERT_GE(m.decode(ev->data, 0, ev->datalen), 0);
      ASSERT_EQ(m.num_contacts, static_cast<int>(m.contacts.size()));
      for (const auto& c : m.contacts) contacts_with_force += c.normal_force > 0 && c.body_a.size() && c.body_b.size();
      ++contacts;
    }
  }
  // paced by simulated time (steps of 1 ms), whatever the wall-clock rate under sanitizers
  const double simulated = 0.001 * JsonNumber(json, "steps");
  EXPECT_NEAR(poses, 50 * simulated, 0.2 * 50 * simulated) << r.output;
  EXPECT_EQ(poses, contacts) << r.output;
  EXPECT_GT(contacts_with_force, 0) << "the grasp's contact forces were published";
}

}  // namespace
}  // namespace gs::tracking
