#include "tracking/lcm_receiver.h"

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "tracking/session_log.h"

namespace gs::tracking {

namespace {

int64_t SystemNanoseconds() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

std::string CheckLcmChannel(const std::string& channel) {
  if (channel.empty()) return "an LCM channel name cannot be empty";
  if (channel.size() > 63) return "LCM channel '" + channel + "' is longer than LCM's 63 characters";
  for (char ch : channel) {
    const bool ok = (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '_' ||
                    ch == '-' || ch == '.' || ch == '/';
    if (!ok)
      return "LCM channel '" + channel + "' has the character '" + std::string(1, ch) +
             "': use letters, digits, _ - . /";
  }
  return "";
}

LcmReceiver::LcmReceiver() = default;
LcmReceiver::~LcmReceiver() { Stop(); }

std::string LcmReceiver::Describe() const {
  return "LCM channel " + channel_ + " (" + (url_.empty() ? std::string("LCM's default URL") : url_) + ")";
}

bool LcmReceiver::Open(const std::string& url, const std::string& channel, std::string* error) {
  Stop();
  const std::string bad = CheckLcmChannel(channel);
  if (!bad.empty()) {
    *error = bad;
    return false;
  }
  url_ = url;
  channel_ = channel;
  lcm_ = std::make_unique<lcm::LCM>(url);
  if (!lcm_->good()) {
    lcm_.reset();
    *error = "LCM is unavailable at '" + (url.empty() ? std::string("udpm://239.255.76.67:7667?ttl=0") : url) +
             "' (a bad URL, or for udpm no multicast route: 'ip route add 239.0.0.0/8 dev lo')";
    return false;
  }
  opened_ns_ = SteadyNanoseconds();
  last_monotonic_ns_ = opened_ns_;
  last_utime_ = 0;
  sequence_ = 0;
  subscription_ = lcm_->subscribe(channel, &LcmReceiver::OnMessage, this);
  if (!subscription_) {
    lcm_.reset();
    *error = "cannot subscribe to LCM channel '" + channel + "'";
    return false;
  }
  // a burst (a tracker at 1 kHz, a thread woken late) waits here rather than being dropped
  subscription_->setQueueCapacity(4096);
  return true;
}

void LcmReceiver::Start(Callback callback) {
  if (!lcm_ || thread_.joinable()) return;
  callback_ = std::move(callback);
  stop_ = false;
  thread_ = std::thread([this] { Loop(); });
}

void LcmReceiver::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (lcm_ && subscription_) lcm_->unsubscribe(subscription_);
  subscription_ = nullptr;
  lcm_.reset();
}

void LcmReceiver::Loop() {
  while (!stop_.load(std::memory_order_relaxed)) {
    // handles what is queued, or waits at most 50 ms for a message
    if (lcm_->handleTimeout(50) < 0) {
      stats_.socket_errors++;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
}

void LcmReceiver::OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
  Datagram d;
  d.monotonic_ns = SteadyNanoseconds();
  const int64_t now_real_ns = SystemNanoseconds();
  // liblcm's stamp (system clock, µs) of the message's arrival: its age when handled moves the
  // steady reading back by as much (never forward, never before Open); stamps never go backwards
  const int64_t age_ns = std::clamp<int64_t>(now_real_ns - rbuf->recv_utime * 1000, 0, d.monotonic_ns - opened_ns_);
  d.monotonic_ns = std::max(d.monotonic_ns - age_ns, last_monotonic_ns_);
  d.utime = std::max((now_real_ns - age_ns) / 1000, last_utime_);
  last_monotonic_ns_ = d.monotonic_ns;
  last_utime_ = d.utime;
  RecordedDatagram m;
  std::string why;
  if (!DecodeDatagram(static_cast<const uint8_t*>(rbuf->data), static_cast<size_t>(rbuf->data_size), &m, &why)) {
    stats_.foreign_messages++;
    return;
  }
  d.data = m.data.data();
  d.size = m.data.size();
  d.truncated = false;  // DecodeDatagram refuses a datagram beyond UdpReceiver::kBufferBytes
  d.sequence = sequence_++;
  std::snprintf(d.source, sizeof(d.source), "%s", m.source.c_str());
  stats_.received++;
  callback_(d);
}

}  // namespace gs::tracking
