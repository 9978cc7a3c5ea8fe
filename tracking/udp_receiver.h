// The UDP receiving end of a DTrack output channel: a socket bound to a port
// (optionally joined to a multicast group, optionally accepting only listed
// senders), 64 KiB datagram buffers, and a thread that hands each datagram, stamped
// with its arrival at the socket, to a callback. The callback runs on the receiver thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace gs::tracking {

struct UdpOptions {
  int port = 5000;                           ///< 0: an ephemeral port (see UdpReceiver::port())
  std::string bind_address = "0.0.0.0";
  std::string multicast_group;               ///< e.g. "224.0.1.0"; empty: unicast only
  std::vector<std::string> allowed_senders;  ///< IPv4 addresses; empty: any
  std::string controller;                    ///< firewall nudge: "fw4dtsdkc\0" to controller:50107 at start
  int socket_buffer_bytes = 4 << 20;         ///< SO_RCVBUF asked for (beyond net.core.rmem_max only as root)
};

struct Datagram {
  const char* data = nullptr;
  size_t size = 0;
  bool truncated = false;       ///< longer than the 64 KiB buffer: only its start is in data
  /// Arrival at the socket (the kernel's SO_TIMESTAMPNS stamp, not the moment the
  /// receiver thread read it): system clock, microseconds since the epoch
  int64_t utime = 0;
  int64_t monotonic_ns = 0;     ///< the same arrival on the steady clock, nanoseconds
  uint64_t sequence = 0;        ///< 0, 1, 2, ... accepted datagrams
  char source[32] = {};         ///< "a.b.c.d:port"
};

struct UdpStats {
  std::atomic<uint64_t> received{0};
  std::atomic<uint64_t> rejected_sender{0};
  std::atomic<uint32_t> last_rejected_addr{0};  ///< IPv4, network byte order
  std::atomic<uint64_t> truncated{0};
  std::atomic<uint64_t> socket_errors{0};
  /// Datagrams the kernel dropped because the socket's receive buffer was full
  /// (SO_RXQ_OVFL): they never reached the socket, so no reader could have seen them.
  std::atomic<uint64_t> kernel_drops{0};
  /// LCM input (LcmReceiver): messages on the channel that are not a graspsim.dtrack_datagram_t
  std::atomic<uint64_t> foreign_messages{0};
};

/// Steady-clock nanoseconds (the clock Datagram::monotonic_ns uses).
int64_t SteadyNanoseconds();

/// Where live's datagrams come from: a UDP socket (UdpReceiver) or an LCM channel
/// (LcmReceiver, tracking/lcm_receiver.h). Each hands every datagram, stamped with its
/// arrival, to the callback on a thread of its own.
class DatagramSource {
 public:
  using Callback = std::function<void(const Datagram&)>;
  virtual ~DatagramSource() = default;
  virtual void Start(Callback callback) = 0;
  /// Stops and joins the thread (within about 50 ms).
  virtual void Stop() = 0;
  virtual const UdpStats& stats() const = 0;
  /// "UDP port 5000", "LCM channel DTRACK_RAW (udpm://...)"
  virtual std::string Describe() const = 0;
};

class UdpReceiver : public DatagramSource {
 public:
  static constexpr size_t kBufferBytes = 65536;

  UdpReceiver() = default;
  UdpReceiver(const UdpReceiver&) = delete;
  UdpReceiver& operator=(const UdpReceiver&) = delete;
  ~UdpReceiver() override;

  /// Creates and binds the socket. False with a message naming what failed.
  bool Open(const UdpOptions& options, std::string* error);
  /// Starts the receiver thread.
  void Start(Callback callback) override;
  /// Stops and joins the thread (within about 50 ms); closes the socket.
  void Stop() override;
  std::string Describe() const override { return "UDP port " + std::to_string(port_); }

  int port() const { return port_; }
  /// The receive buffer the kernel granted (Linux reports twice the size asked for).
  int receive_buffer_bytes() const { return rcvbuf_granted_; }
  const UdpStats& stats() const override { return stats_; }

 private:
  void Loop();
  int fd_ = -1;
  int port_ = 0;
  int rcvbuf_granted_ = 0;
  int64_t opened_ns_ = 0;  // steady clock, just before the socket was bound
  std::vector<uint32_t> allowed_;  // network byte order
  Callback callback_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  UdpStats stats_;
};

/// Sends datagrams to host:port (IPv4).
class UdpSender {
 public:
  ~UdpSender();
  bool Open(const std::string& host, int port, std::string* error);
  bool Send(const char* data, size_t size);
  uint64_t errors() const { return errors_; }

 private:
  int fd_ = -1;
  char addr_[16] = {};  // sockaddr_in
  uint64_t errors_ = 0;
};

}  // namespace gs::tracking
