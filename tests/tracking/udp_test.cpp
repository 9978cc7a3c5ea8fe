// The UDP receiver on loopback: every datagram arrives whole, stamped and
// numbered; the sender allow-list rejects others; bad options are refused.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <thread>

#include "tracking/udp_receiver.h"

namespace gs::tracking {
namespace {

struct Collected {
  std::mutex mu;
  std::vector<std::string> data;
  std::vector<uint64_t> sequence;
  std::vector<int64_t> arrival;  // steady clock, ns
  std::vector<int64_t> utime;    // system clock, us
  std::string source;
};

template <class Done>
void SendAndWait(int port, int n, Done done) {
  UdpSender tx;
  std::string error;
  ASSERT_TRUE(tx.Open("127.0.0.1", port, &error)) << error;
  for (int i = 0; i < n; ++i) {
    const std::string s = "fr " + std::to_string(i) + "\r\n" + std::string(static_cast<size_t>(i) * 1000, 'x');
    ASSERT_TRUE(tx.Send(s.data(), s.size()));
  }
  for (int k = 0; k < 400 && !done(); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

TEST(UdpReceiver, DatagramsArriveWholeStampedAndNumbered) {
  UdpReceiver rx;
  UdpOptions o;
  o.port = 0;
  o.bind_address = "127.0.0.1";
  std::string error;
  ASSERT_TRUE(rx.Open(o, &error)) << error;
  ASSERT_GT(rx.port(), 0);
  Collected c;
  rx.Start([&](const Datagram& d) {
    std::lock_guard<std::mutex> lock(c.mu);
    c.data.emplace_back(d.data, d.size);
    c.sequence.push_back(d.sequence);
    c.arrival.push_back(d.monotonic_ns);
    c.source = d.source;
    EXPECT_FALSE(d.truncated);
    EXPECT_GT(d.utime, 1600000000000000);
  });
  const int64_t before = SteadyNanoseconds();
  SendAndWait(rx.port(), 40, [&] { return rx.stats().received.load() >= 40; });  // up to 39 KB each
  rx.Stop();
  ASSERT_EQ(c.data.size(), 40u);
  for (int i = 0; i < 40; ++i) {
    EXPECT_EQ(c.data[i].size(), std::to_string(i).size() + 5 + 1000u * i);
    EXPECT_EQ(c.sequence[i], static_cast<uint64_t>(i));
    EXPECT_GE(c.arrival[i], before);
    if (i) {
      EXPECT_GE(c.arrival[i], c.arrival[i - 1]);
    }
  }
  EXPECT_EQ(c.source.rfind("127.0.0.1:", 0), 0u) << c.source;
  EXPECT_EQ(rx.stats().received.load(), 40u);
}

// Datagrams that wait in the socket (a receiver thread started late, or woken late on a
// loaded machine) keep the times they arrived at, not the time they were read.
TEST(UdpReceiver, DatagramsQueuedBeforeTheThreadReadsThemKeepTheirArrivalTimes) {
  // The kernel turns its receive stamping on shortly after the first socket in the system
  // asks for it (a deferred work item, slow on a loaded machine); datagrams queued before
  // that are stamped when read. The first receiver stays open, keeping stamping on, while
  // later attempts run; read-time stamps could never pass the spacing check below.
  std::vector<std::unique_ptr<UdpReceiver>> receivers;
  for (int attempt = 0; attempt < 20; ++attempt) {
    auto& rx = *receivers.emplace_back(std::make_unique<UdpReceiver>());
    UdpOptions o;
    o.port = 0;
    o.bind_address = "127.0.0.1";
    std::string error;
    ASSERT_TRUE(rx.Open(o, &error)) << error;
    UdpSender tx;
    ASSERT_TRUE(tx.Open("127.0.0.1", rx.port(), &error)) << error;
    std::vector<int64_t> sent;
    for (int i = 0; i < 3; ++i) {
      if (i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      sent.push_back(SteadyNanoseconds());
      ASSERT_TRUE(tx.Send("fr 1\r\n", 6));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const int64_t started = SteadyNanoseconds();
    Collected c;
    rx.Start([&](const Datagram& d) {
      std::lock_guard<std::mutex> lock(c.mu);
      c.arrival.push_back(d.monotonic_ns);
      c.utime.push_back(d.utime);
    });
    for (int k = 0; k < 400 && rx.stats().received.load() < 3; ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    rx.Stop();
    ASSERT_EQ(c.arrival.size(), 3u);
    if (c.arrival[2] >= started && attempt < 19) continue;  // stamping was not on yet
    for (int i = 0; i < 3; ++i) {
      // each stamp lies between its send and the next (loopback delivers within the call)
      EXPECT_GE(c.arrival[i], sent[i]) << i;
      EXPECT_LT(c.arrival[i], i < 2 ? sent[i + 1] : started) << i;
      if (i) {
        // the system-clock stamp moves with the steady one (to a few ms, should the clock be stepped)
        const double steady_ms = 1e-6 * static_cast<double>(c.arrival[i] - c.arrival[i - 1]);
        const double system_ms = 1e-3 * static_cast<double>(c.utime[i] - c.utime[i - 1]);
        EXPECT_GE(steady_ms, 95.0) << i;
        EXPECT_NEAR(system_ms, steady_ms, 5.0) << i;
      }
    }
    std::printf("stamps taken by the kernel from attempt %d on\n", attempt);
    return;
  }
}

TEST(UdpReceiver, AllowListRejectsOtherSenders) {
  for (const char* allowed : {"10.11.12.13", "127.0.0.1"}) {
    UdpReceiver rx;
    UdpOptions o;
    o.port = 0;
    o.bind_address = "127.0.0.1";
    o.allowed_senders = {allowed};
    std::string error;
    ASSERT_TRUE(rx.Open(o, &error)) << error;
    Collected c;
    rx.Start([&](const Datagram& d) {
      std::lock_guard<std::mutex> lock(c.mu);
      c.data.emplace_back(d.data, d.size);
    });
    const bool loopback = std::string(allowed) == "127.0.0.1";
    SendAndWait(rx.port(), 5, [&] { return rx.stats().received.load() + rx.stats().rejected_sender.load() >= 5; });
    rx.Stop();
    EXPECT_EQ(c.data.size(), loopback ? 5u : 0u) << allowed;
    EXPECT_EQ(rx.stats().rejected_sender.load(), loopback ? 0u : 5u) << allowed;
  }
}

TEST(UdpReceiver, BadOptionsAreRefusedWithAMessage) {
  UdpReceiver rx;
  std::string error;
  UdpOptions o;
  o.port = 0;
  o.multicast_group = "10.0.0.1";
  EXPECT_FALSE(rx.Open(o, &error));
  EXPECT_NE(error.find("multicast"), std::string::npos) << error;
  o = UdpOptions();
  o.port = 0;
  o.allowed_senders = {"not-an-address"};
  EXPECT_FALSE(rx.Open(o, &error));
  EXPECT_NE(error.find("not-an-address"), std::string::npos) << error;
  o = UdpOptions();
  o.port = 70000;
  EXPECT_FALSE(rx.Open(o, &error));
  UdpSender tx;
  EXPECT_FALSE(tx.Open("localhost", 5000, &error));  // IPv4 literals only
  EXPECT_NE(error.find("localhost"), std::string::npos);
}

}  // namespace
}  // namespace gs::tracking
