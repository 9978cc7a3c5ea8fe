// DTrack datagrams from an LCM channel instead of a UDP socket: the
// graspsim.dtrack_datagram_t messages that `graspsim record` logs (channel
// DTRACK_RAW), published by `lcm-logplayer` from a recorded session or by
// `graspsim bridge` from a tracker's live UDP stream. A thread of its own handles
// LCM (waking every 50 ms to look at its stop flag) and hands each datagram to the
// callback, as UdpReceiver does, so that live's simulation thread never waits on LCM.
//
// Arrival stamp: the moment this host received the LCM message, as liblcm stamped it
// (lcm::ReceiveBuffer::recv_utime: for udpm the kernel's receive time of its packet),
// moved to the steady clock by its age when handled. The message's own utime and
// monotonic_utime (the original UDP arrival, on the recording or bridging host's clocks)
// are not used: they belong to another time and, for a bridge, another machine.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "tracking/udp_receiver.h"

namespace lcm {
class LCM;
class ReceiveBuffer;
class Subscription;
}  // namespace lcm

namespace gs::tracking {

/// Empty when `channel` can name an LCM channel (1 to 63 of A-Z a-z 0-9 _ - . /, as
/// LCM subscribes by regular expression and these match themselves but '.'), else why not.
std::string CheckLcmChannel(const std::string& channel);

class LcmReceiver : public DatagramSource {
 public:
  LcmReceiver();
  LcmReceiver(const LcmReceiver&) = delete;
  LcmReceiver& operator=(const LcmReceiver&) = delete;
  ~LcmReceiver() override;

  /// Connects to `url` (empty: LCM's default) and subscribes to `channel`; messages
  /// are queued from here on. False with a message naming what failed.
  bool Open(const std::string& url, const std::string& channel, std::string* error);
  void Start(Callback callback) override;
  void Stop() override;
  const UdpStats& stats() const override { return stats_; }
  std::string Describe() const override;

 private:
  void Loop();
  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  std::unique_ptr<lcm::LCM> lcm_;
  lcm::Subscription* subscription_ = nullptr;
  std::string url_, channel_;
  Callback callback_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  UdpStats stats_;
  int64_t opened_ns_ = 0, last_monotonic_ns_ = 0, last_utime_ = 0;
  uint64_t sequence_ = 0;
};

}  // namespace gs::tracking
