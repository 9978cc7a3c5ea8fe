// The UDP receiver on loopback: every datagram arrives whole, stamped and
// numbered; the sender allow-list rejects others; bad options are refused.
#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <thread>

#include "tracking/udp_receiver.h"

namespace gs::tracking {
namespace {

struct Collected {
  std::mutex mu;
  std::vector<std::string> data;
  std::vector<uint64_t> sequence;
  std::vector<int64_t> arrival;
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
