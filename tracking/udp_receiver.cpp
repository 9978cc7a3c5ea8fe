#include "tracking/udp_receiver.h"

#include <arpa/inet.h>
#include <linux/sock_diag.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <vector>

namespace gs::tracking {

int64_t SteadyNanoseconds() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

namespace {

int64_t SystemNanoseconds() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

bool ParseIpv4(const std::string& s, in_addr* out) { return inet_pton(AF_INET, s.c_str(), out) == 1; }

}  // namespace

UdpReceiver::~UdpReceiver() { Stop(); }

bool UdpReceiver::Open(const UdpOptions& o, std::string* error) {
  Stop();
  auto fail = [&](const std::string& what) {
    *error = what + (errno ? std::string(": ") + std::strerror(errno) : std::string());
    if (fd_ >= 0) close(fd_);
    fd_ = -1;
    return false;
  };
  errno = 0;
  if (o.port < 0 || o.port > 65535) return fail("UDP port " + std::to_string(o.port) + " out of [0, 65535]");
  allowed_.clear();
  for (const std::string& s : o.allowed_senders) {
    in_addr a;
    if (!ParseIpv4(s, &a)) return fail("allowed sender '" + s + "' is not an IPv4 address");
    allowed_.push_back(a.s_addr);
  }
  in_addr bind_addr, group{};
  if (!ParseIpv4(o.bind_address, &bind_addr)) return fail("bind address '" + o.bind_address + "' is not an IPv4 address");
  if (!o.multicast_group.empty() && (!ParseIpv4(o.multicast_group, &group) || (ntohl(group.s_addr) >> 28) != 0xE))
    return fail("multicast group '" + o.multicast_group + "' is not an IPv4 multicast address (224.0.0.0/4)");
  fd_ = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd_ < 0) return fail("cannot create a UDP socket");
  const int one = 1;
  setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  if (o.socket_buffer_bytes < 4096 || o.socket_buffer_bytes > (1 << 30))
    return fail("socket receive buffer " + std::to_string(o.socket_buffer_bytes) + " bytes out of [4096, 2^30]");
  const int rcvbuf = o.socket_buffer_bytes;
  setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
  {
    // SO_RCVBUF is capped at net.core.rmem_max; with CAP_NET_ADMIN the cap can be passed
    int granted = 0;
    socklen_t glen = sizeof(granted);
    getsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &granted, &glen);
    if (granted / 2 < rcvbuf) setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &rcvbuf, sizeof(rcvbuf));
    glen = sizeof(granted);
    getsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &granted, &glen);
    rcvbuf_granted_ = granted;
  }
  // the kernel counts the datagrams it drops on a full buffer and tells us with each datagram
  setsockopt(fd_, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof(one));
  // and stamps each datagram when it reaches the socket: a receiver thread woken late (a
  // loaded machine, the datagrams queued before it started) still sees the true arrivals
  setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof(one));
  errno = 0;
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<uint16_t>(o.port));
  sa.sin_addr = o.multicast_group.empty() ? bind_addr : in_addr{htonl(INADDR_ANY)};
  opened_ns_ = SteadyNanoseconds();  // no datagram reaches the socket before it is bound
  if (bind(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof(sa)) != 0)
    return fail("cannot bind UDP port " + std::to_string(o.port));
  socklen_t len = sizeof(sa);
  getsockname(fd_, reinterpret_cast<sockaddr*>(&sa), &len);
  port_ = ntohs(sa.sin_port);
  if (!o.multicast_group.empty()) {
    ip_mreq m{};
    m.imr_multiaddr = group;
    m.imr_interface = bind_addr;
    if (setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof(m)) != 0)
      return fail("cannot join multicast group " + o.multicast_group);
  }
  if (!o.controller.empty()) {
    // the SDK's firewall nudge: one small datagram to the Controller's sending port
    in_addr c;
    if (!ParseIpv4(o.controller, &c)) return fail("controller '" + o.controller + "' is not an IPv4 address");
    sockaddr_in ca{};
    ca.sin_family = AF_INET;
    ca.sin_port = htons(50107);
    ca.sin_addr = c;
    static const char kNudge[] = "fw4dtsdkc";  // sent with its NUL
    if (sendto(fd_, kNudge, sizeof(kNudge), 0, reinterpret_cast<sockaddr*>(&ca), sizeof(ca)) < 0)
      return fail("cannot send the firewall nudge to " + o.controller + ":50107");
  }
  return true;
}

void UdpReceiver::Start(Callback callback) {
  if (fd_ < 0 || thread_.joinable()) return;
  callback_ = std::move(callback);
  stop_ = false;
  thread_ = std::thread([this] { Loop(); });
}

void UdpReceiver::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) {
    // the datagrams' SO_RXQ_OVFL counts miss drops after the last datagram read: ask the socket itself
    uint32_t mem[SK_MEMINFO_VARS] = {};
    socklen_t len = sizeof(mem);
    if (getsockopt(fd_, SOL_SOCKET, SO_MEMINFO, mem, &len) == 0 && len >= sizeof(uint32_t) * (SK_MEMINFO_DROPS + 1) &&
        mem[SK_MEMINFO_DROPS] > stats_.kernel_drops.load())
      stats_.kernel_drops.store(mem[SK_MEMINFO_DROPS]);
    close(fd_);
  }
  fd_ = -1;
}

void UdpReceiver::Loop() {
  std::vector<char> buffer(kBufferBytes + 1);
  uint64_t sequence = 0;
  int64_t last_monotonic_ns = opened_ns_, last_utime = 0;
  while (!stop_.load(std::memory_order_relaxed)) {
    pollfd p{fd_, POLLIN, 0};
    const int r = poll(&p, 1, 50);
    if (r <= 0) {
      if (r < 0 && errno != EINTR) stats_.socket_errors++;
      continue;
    }
    // drain everything queued, each datagram stamped as it is read
    for (;;) {
      sockaddr_in from{};
      iovec iov{buffer.data(), kBufferBytes};
      alignas(cmsghdr) char control[CMSG_SPACE(sizeof(uint32_t)) + CMSG_SPACE(sizeof(timespec))];
      msghdr msg{};
      msg.msg_name = &from;
      msg.msg_namelen = sizeof(from);
      msg.msg_iov = &iov;
      msg.msg_iovlen = 1;
      msg.msg_control = control;
      msg.msg_controllen = sizeof(control);
      const ssize_t n = recvmsg(fd_, &msg, MSG_DONTWAIT | MSG_TRUNC);
      if (n < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) stats_.socket_errors++;
        break;
      }
      Datagram d;
      d.monotonic_ns = SteadyNanoseconds();
      const int64_t read_real_ns = SystemNanoseconds();
      int64_t arrival_real_ns = read_real_ns;
      for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
          uint32_t dropped = 0;  // the socket's running count
          std::memcpy(&dropped, CMSG_DATA(c), sizeof(dropped));
          stats_.kernel_drops.store(dropped, std::memory_order_relaxed);
        } else if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
          timespec ts{};
          std::memcpy(&ts, CMSG_DATA(c), sizeof(ts));
          arrival_real_ns = static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
        }
      }
      // the kernel's stamp is on the system clock: the datagram's age when read moves the
      // steady clock's reading back by as much (never forward, never before the socket opened).
      // Stamps never go backwards from one datagram to the next: loopback may deliver a few
      // out of order, and datagrams the kernel queued before it had turned its stamping on
      // (it does so shortly after the socket asks) carry the time they were read instead.
      const int64_t age_ns = std::clamp<int64_t>(read_real_ns - arrival_real_ns, 0, d.monotonic_ns - opened_ns_);
      d.monotonic_ns = std::max(d.monotonic_ns - age_ns, last_monotonic_ns);
      d.utime = std::max((read_real_ns - age_ns) / 1000, last_utime);
      last_monotonic_ns = d.monotonic_ns;
      last_utime = d.utime;
      if (!allowed_.empty()) {
        bool ok = false;
        for (uint32_t a : allowed_) ok = ok || a == from.sin_addr.s_addr;
        if (!ok) {
          stats_.last_rejected_addr.store(from.sin_addr.s_addr, std::memory_order_relaxed);
          stats_.rejected_sender++;
          continue;
        }
      }
      d.data = buffer.data();
      d.truncated = static_cast<size_t>(n) > kBufferBytes;
      d.size = d.truncated ? kBufferBytes : static_cast<size_t>(n);
      if (d.truncated) stats_.truncated++;
      d.sequence = sequence++;
      char ip[INET_ADDRSTRLEN] = {};
      inet_ntop(AF_INET, &from.sin_addr, ip, sizeof(ip));
      std::snprintf(d.source, sizeof(d.source), "%s:%u", ip, static_cast<unsigned>(ntohs(from.sin_port)));
      stats_.received++;
      callback_(d);
    }
  }
}

UdpSender::~UdpSender() {
  if (fd_ >= 0) close(fd_);
}

bool UdpSender::Open(const std::string& host, int port, std::string* error) {
  in_addr a;
  if (inet_pton(AF_INET, host.c_str(), &a) != 1) {
    *error = "host '" + host + "' is not an IPv4 address";
    return false;
  }
  if (port <= 0 || port > 65535) {
    *error = "UDP port " + std::to_string(port) + " out of [1, 65535]";
    return false;
  }
  fd_ = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd_ < 0) {
    *error = std::string("cannot create a UDP socket: ") + std::strerror(errno);
    return false;
  }
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<uint16_t>(port));
  sa.sin_addr = a;
  static_assert(sizeof(sa) <= sizeof(addr_), "sockaddr_in fits");
  std::memcpy(addr_, &sa, sizeof(sa));
  return true;
}

bool UdpSender::Send(const char* data, size_t size) {
  const ssize_t n = sendto(fd_, data, size, 0, reinterpret_cast<const sockaddr*>(addr_), sizeof(sockaddr_in));
  if (n != static_cast<ssize_t>(size)) {
    ++errors_;
    return false;
  }
  return true;
}

}  // namespace gs::tracking
