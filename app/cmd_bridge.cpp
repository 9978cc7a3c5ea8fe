// `graspsim bridge --port P [--channel C] [--lcm-url URL]`: on the tracker's
// host, forwards every DTrack UDP datagram, unmodified and stamped with its
// arrival, as a graspsim.dtrack_datagram_t on an LCM channel (DTRACK_RAW, what
// `graspsim record` logs), so that any number of hosts run `graspsim live
// --tracker lcm` on one tracker. Ctrl-C stops.
#include <chrono>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <thread>

#include "app/cli_help.h"
#include "app/commands.h"
#include "session/tracker_app.h"
#include "tracking/lcm_receiver.h"
#include "tracking/session_log.h"

namespace gs::app {
namespace {

struct BridgeOptions {
  tracking::UdpOptions udp;
  std::string channel = tracking::kRawChannel;
  std::string lcm_url;
  double duration = 0.0;
  bool quiet = false;
};

int Bridge(const BridgeOptions& opt) {
  std::string error;
  const std::string bad = tracking::CheckLcmChannel(opt.channel);
  if (!bad.empty()) {
    std::fprintf(stderr, "bridge: --channel: %s\n", bad.c_str());
    return kExitUsage;
  }
  lcm::LCM lc(opt.lcm_url);
  if (!lc.good()) {
    std::fprintf(stderr, "bridge: LCM is unavailable at '%s' (a bad URL, or for udpm no multicast route: 'ip route "
                         "add 239.0.0.0/8 dev lo')\n",
                 opt.lcm_url.empty() ? "udpm://239.255.76.67:7667?ttl=0" : opt.lcm_url.c_str());
    return kExitBadInput;
  }
  tracking::UdpReceiver rx;
  if (!rx.Open(opt.udp, &error)) {
    std::fprintf(stderr, "bridge: %s\n", error.c_str());
    return kExitBadInput;
  }
  // the receiver thread alone publishes (one LCM user) and parses for the error counts
  std::atomic<uint64_t> forwarded{0}, publish_errors{0}, parse_errors{0};
  std::atomic<int64_t> first_ns{-1}, last_ns{-1};
  tracking::DTrackParser parser;
  tracking::DTrackFrame frame;
  rx.Start([&](const tracking::Datagram& d) {
    const std::vector<uint8_t> msg = tracking::EncodeDatagram(d);
    if (lc.publish(opt.channel, msg.data(), static_cast<unsigned>(msg.size())) == 0)
      forwarded.fetch_add(1);
    else
      publish_errors.fetch_add(1);
    if (d.truncated)
      parser.CountOversized(d.size);
    else
      parser.Parse(d.data, d.size, &frame);
    parse_errors = parser.stats().TotalErrors();
    if (first_ns.load() < 0) first_ns = d.monotonic_ns;
    last_ns = d.monotonic_ns;
  });
  std::printf("bridge: listening on UDP port %d%s%s, publishing on LCM channel %s (%s) (Ctrl-C stops)\n", rx.port(),
              opt.udp.multicast_group.empty() ? "" : " group ", opt.udp.multicast_group.c_str(), opt.channel.c_str(),
              opt.lcm_url.empty() ? "LCM's default URL" : opt.lcm_url.c_str());
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  const bool tty = StdoutIsTerminal() && !opt.quiet;
  while (!StopRequested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (opt.duration > 0 && elapsed >= opt.duration) break;
    if (tty) {
      std::printf("\r  %.1f s  %llu datagrams forwarded  %llu parse errors   ", elapsed,
                  static_cast<unsigned long long>(forwarded.load()),
                  static_cast<unsigned long long>(parse_errors.load()));
      std::fflush(stdout);
    }
  }
  rx.Stop();
  if (tty) std::printf("\n");
  const uint64_t n = forwarded.load();
  const double span = n > 1 ? 1e-9 * static_cast<double>(last_ns.load() - first_ns.load()) : 0.0;
  std::printf("bridge: %llu datagrams (%.1f Hz) forwarded to LCM channel %s; %llu publish errors; parse errors %s; "
              "%llu rejected senders; the kernel dropped %llu (receive buffer full)\n",
              static_cast<unsigned long long>(n), span > 0 ? static_cast<double>(n - 1) / span : 0.0,
              opt.channel.c_str(), static_cast<unsigned long long>(publish_errors.load()),
              FormatParseErrors(parser.stats()).c_str(),
              static_cast<unsigned long long>(rx.stats().rejected_sender.load()),
              static_cast<unsigned long long>(rx.stats().kernel_drops.load()));
  return publish_errors.load() ? kExitFailure : kExitOk;
}

}  // namespace

void AddBridgeCommand(CLI::App& app, int* exit_code) {
  auto opt = std::make_shared<BridgeOptions>();
  CLI::App* cmd =
      app.add_subcommand("bridge", "Forward DTrack UDP datagrams to an LCM channel, for live on any number of hosts");
  AddUdpReceiveOptions(cmd, &opt->udp);
  cmd->add_option("--channel", opt->channel,
                  "LCM channel of the graspsim.dtrack_datagram_t messages (live --tracker lcm:CHANNEL)")
      ->type_name("CHANNEL")
      ->capture_default_str();
  cmd->add_option("--lcm-url", opt->lcm_url, "LCM URL (default: LCM's default, udpm://239.255.76.67:7667?ttl=0)")
      ->type_name("URL");
  cmd->add_option("--duration", opt->duration, "stop after this many seconds (default: at Ctrl-C)")
      ->type_name("SECONDS")
      ->check(Positive("number of seconds"));
  cmd->add_flag("--quiet", opt->quiet, "no status line");
  SetHelpFooter(cmd,
                {{"graspsim bridge --port 5000 --lcm-url 'udpm://239.255.76.67:7667?ttl=1'",
                  "on the tracker's host: every datagram arriving on UDP port 5000 goes to channel DTRACK_RAW on the "
                  "lab network (ttl=1), where graspsim live --tracker lcm --lcm-url 'udpm://239.255.76.67:7667?ttl=1' "
                  "takes it on each simulation host"},
                 {"graspsim bridge --port 5000 --channel HAND_A --duration 60",
                  "one minute, on channel HAND_A (live --tracker lcm:HAND_A)"}},
                {{kExitOk, "the bridge ended (--duration or Ctrl-C) and every datagram received was published"},
                 {kExitFailure, "a datagram could not be published on LCM"},
                 {kExitUsage, "bad command line (a channel name LCM cannot take)"},
                 {kExitBadInput, "the UDP port cannot be opened, or LCM is unavailable at the URL"}});
  cmd->callback([opt, exit_code]() { *exit_code = Bridge(*opt); });
}

}  // namespace gs::app
