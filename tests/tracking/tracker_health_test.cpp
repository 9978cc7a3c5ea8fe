// TrackerHealth on made-up timelines: each fault gives its event once, at the
// right time, and the state returns to ok when good data comes back.
#include <gtest/gtest.h>

#include <arpa/inet.h>

#include <string>
#include <vector>

#include "tracking/tracker_health.h"

namespace gs::tracking {
namespace {

// A tracker timeline sampled every 20 ms, as live's calling thread does.
class Timeline {
 public:
  Timeline() { health_.Start(0); }
  // `seconds` of datagrams at `hz` (bad: that many more per second that do not parse;
  // rejected: that many per second from 10.0.0.9, outside the allow list)
  void Run(double seconds, double hz, double bad_hz = 0, double rejected_hz = 0) {
    const int64_t tick = 20000000;
    const double dt = 1e-9 * static_cast<double>(tick);
    // fractional datagrams carried from tick to tick
    auto due = [&](double rate, double* acc) {
      *acc += rate * dt;
      const uint64_t n = static_cast<uint64_t>(*acc);
      *acc -= static_cast<double>(n);
      return n;
    };
    for (int64_t end = now_ + static_cast<int64_t>(seconds * 1e9); now_ < end;) {
      now_ += tick;
      const uint64_t good = due(hz, &good_acc_);
      const uint64_t bad = due(bad_hz, &bad_acc_);
      c_.datagrams += good + bad;
      c_.bad_datagrams += bad;
      if (good + bad) c_.last_arrival_ns = now_;
      const uint64_t rej = due(rejected_hz, &rej_acc_);
      c_.rejected += rej;
      if (rej) inet_pton(AF_INET, "10.0.0.9", &c_.last_rejected_addr);
      c_.now_ns = now_;
      HealthEvent ev[TrackerHealth::kMaxEvents];
      const int n = health_.Update(c_, ev);
      for (int i = 0; i < n; ++i) events_.push_back(ev[i]);
    }
  }
  const std::vector<HealthEvent>& events() const { return events_; }
  const TrackerHealth& health() const { return health_; }
  int Count(EHealthEvent k) const {
    int n = 0;
    for (const auto& e : events_) n += e.kind == k;
    return n;
  }
  const HealthEvent* First(EHealthEvent k) const {
    for (const auto& e : events_)
      if (e.kind == k) return &e;
    return nullptr;
  }

 private:
  TrackerHealth health_;
  HealthCounters c_;
  int64_t now_ = 0;
  double good_acc_ = 0, bad_acc_ = 0, rej_acc_ = 0;
  std::vector<HealthEvent> events_;
};

TEST(TrackerHealth, SteadyTrackerSettlesItsRateAndStaysQuiet) {
  Timeline t;
  t.Run(10.0, 100.0);
  ASSERT_EQ(t.events().size(), 1u);
  EXPECT_EQ(t.events()[0].kind, EHealthEvent::Rate);
  EXPECT_NEAR(t.health().settled_rate_hz(), 100.0, 3.0);
  EXPECT_STREQ(t.health().state(), "ok");
  EXPECT_EQ(t.health().counts().silences, 0);
}

TEST(TrackerHealth, NothingAtAllIsReportedOnce) {
  Timeline t;
  t.Run(5.0, 0.0);
  EXPECT_EQ(t.Count(EHealthEvent::NoData), 1);
  EXPECT_STREQ(t.health().state(), "waiting");
}

TEST(TrackerHealth, StopAndRestartAtAnotherRate) {
  Timeline t;
  t.Run(3.0, 100.0);
  t.Run(2.0, 0.0);  // tracker stopped
  ASSERT_EQ(t.Count(EHealthEvent::Silent), 1);
  const HealthEvent* silent = t.First(EHealthEvent::Silent);
  EXPECT_GT(silent->t_s, 3.2);  // reported after 0.25 s of silence, within a tick
  EXPECT_LT(silent->t_s, 3.32);
  EXPECT_STREQ(t.health().state(), "silent");
  t.Run(4.0, 60.0);  // restarted at 60 Hz
  ASSERT_EQ(t.Count(EHealthEvent::Back), 1);
  EXPECT_LT(t.First(EHealthEvent::Back)->t_s, 5.05);
  EXPECT_EQ(t.health().counts().rate_changes, 1);
  EXPECT_NEAR(t.health().settled_rate_hz(), 60.0, 3.0);
  EXPECT_NE(std::string(t.events().back().text).find("from 100"), std::string::npos) << t.events().back().text;
  EXPECT_STREQ(t.health().state(), "ok");
}

TEST(TrackerHealth, JitterIsNotARateChange) {
  Timeline t;
  t.Run(2.0, 100.0);
  for (int i = 0; i < 10; ++i) t.Run(0.5, i % 2 ? 110.0 : 90.0);
  EXPECT_EQ(t.health().counts().rate_changes, 0);
}

TEST(TrackerHealth, GarbageFloodAndStrangersAreReportedAndEnd) {
  Timeline t;
  t.Run(2.0, 100.0);
  t.Run(1.0, 100.0, 50.0);  // garbage among good frames
  t.Run(1.0, 100.0);
  EXPECT_EQ(t.Count(EHealthEvent::Garbage), 1);
  EXPECT_EQ(t.Count(EHealthEvent::GarbageOver), 1);
  t.Run(1.0, 100.0, 20000.0);  // a flood of garbage
  EXPECT_STREQ(t.health().state(), "flood");
  t.Run(1.5, 100.0);
  EXPECT_EQ(t.Count(EHealthEvent::Flood), 1);
  EXPECT_EQ(t.Count(EHealthEvent::FloodOver), 1);
  t.Run(1.0, 100.0, 0.0, 20000.0);  // a flood from outside the allow list
  EXPECT_EQ(t.Count(EHealthEvent::Rejected), 1);
  EXPECT_NE(std::string(t.First(EHealthEvent::Rejected)->text).find("10.0.0.9"), std::string::npos);
  EXPECT_EQ(t.Count(EHealthEvent::Flood), 1) << "rejected datagrams never reach the simulation: no flood";
  t.Run(1.5, 100.0);
  EXPECT_EQ(t.Count(EHealthEvent::RejectedOver), 1);
  EXPECT_STREQ(t.health().state(), "ok");
  EXPECT_EQ(t.health().counts().rate_changes, 0) << "faults are not rate changes";
  EXPECT_NEAR(t.health().settled_rate_hz(), 100.0, 5.0);
}

}  // namespace
}  // namespace gs::tracking
