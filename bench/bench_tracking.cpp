// `graspsim bench tracking`: the DTrack input path.
//   parse       parser throughput on five-finger hand datagrams (lines/s, µs per datagram)
//   receive     10,000 five-finger datagrams per second over loopback UDP into the
//               live loop (receiver thread -> mailbox -> 1 kHz simulation thread):
//               datagrams received and parsed, and whether the simulation kept its rate
//   latency     100 Hz datagrams into the live loop: from a datagram's arrival to the end
//               of the simulation step whose fingertip coupling force it set, in steps
//               (counted from the step in progress at arrival) and µs
// The last JSON line holds parse_lines_per_s and latency_steps (target: 1 step or less).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>
#include <vector>

#include "bench/bench.h"
#include "scene/exit_code.h"
#include "session/live_loop.h"
#include "scene/paths.h"
#include "session/tracked_sim.h"
#include "tracking/dtrack_parser.h"
#include "tracking/hand_mapping.h"
#include "tracking/synthetic_hand.h"
#include "tracking/udp_receiver.h"

namespace gs::app {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1) + 0.5))];
}

// sends `datagrams` to 127.0.0.1:port at `rate` Hz (absolute deadlines), starting after `delay_s`
void SendAt(int port, const std::vector<std::string>& datagrams, double rate, double delay_s, uint64_t* sent) {
  tracking::UdpSender tx;
  std::string error;
  if (!tx.Open("127.0.0.1", port, &error)) return;
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(delay_s));
  for (size_t i = 0; i < datagrams.size(); ++i) {
    std::this_thread::sleep_until(t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(i / rate)));
    *sent += tx.Send(datagrams[i].data(), datagrams[i].size());
  }
}

struct LiveRun {
  LiveStats stats;
  uint64_t sent = 0;
  bool ok = false;
};

LiveRun RunWithSender(const std::vector<std::string>& datagrams, double rate, double duration) {
  LiveRun run;
  auto sim = std::make_unique<TrackedSim>();
  std::string error;
  if (!sim->Load(ResolveResource("config/tracked_hand.yaml"), &error)) {
    std::fprintf(stderr, "bench tracking: %s\n", error.c_str());
    return run;
  }
  LiveOptions o;
  o.udp.port = 0;  // the receiver takes a free port; the sender needs it first
  tracking::UdpReceiver probe;
  if (!probe.Open(o.udp, &error)) {
    std::fprintf(stderr, "bench tracking: %s\n", error.c_str());
    return run;
  }
  o.udp.port = probe.port();
  probe.Stop();
  o.duration = duration;
  o.publish_rate = 0.0;
  o.status = false;
  o.quiet = true;
  std::thread sender(SendAt, o.udp.port, std::cref(datagrams), rate, 0.3, &run.sent);
  run.ok = RunLive(*sim, o, &run.stats, &error);
  sender.join();
  if (!run.ok) std::fprintf(stderr, "bench tracking: %s\n", error.c_str());
  return run;
}

}  // namespace

int RunBenchTracking(const BenchOptions& opt) {
  const int reps = opt.quick ? 3 : 7;
  // --- parse throughput: five-finger hands over a whole synthetic grasp
  tracking::SyntheticHand hand;
  hand.fingers = 5;
  std::vector<std::string> packets;
  for (int i = 0; i < 290; ++i) packets.push_back(hand.Datagram(i * 0.01, static_cast<uint32_t>(i + 1)));
  size_t lines_per_pass = 0, bytes_per_pass = 0;
  for (const std::string& p : packets) {
    lines_per_pass += static_cast<size_t>(std::count(p.begin(), p.end(), '\n'));
    bytes_per_pass += p.size();
  }
  tracking::DTrackParser parser;
  tracking::DTrackFrame frame;
  tracking::TrackerConfig cfg;
  for (int f = 0; f < 3; ++f) {
    tracking::FingertipMap m;
    m.finger = f;
    cfg.fingertips.push_back(m);
  }
  tracking::TargetSample sample;
  const int passes = opt.quick ? 20 : 70;
  std::vector<double> lines_per_s, us_per_datagram, us_parse_map;
  int errors = 0;
  for (int r = 0; r < reps; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < passes; ++k)
      for (const std::string& p : packets) errors += parser.Parse(p.data(), p.size(), &frame);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    lines_per_s.push_back(static_cast<double>(lines_per_pass) * passes / s);
    us_per_datagram.push_back(1e6 * s / (static_cast<double>(packets.size()) * passes));
    t0 = std::chrono::steady_clock::now();
    for (const std::string& p : packets) {
      parser.Parse(p.data(), p.size(), &frame);
      tracking::MapFrame(frame, cfg, &sample);
    }
    us_parse_map.push_back(1e6 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() /
                           static_cast<double>(packets.size()));
  }
  const double parse_lines = Median(lines_per_s), parse_us = Median(us_per_datagram), map_us = Median(us_parse_map);
  const double parse_mb = parse_lines / static_cast<double>(lines_per_pass) * static_cast<double>(bytes_per_pass) / 1e6;
  if (opt.json)
    std::printf("{\"bench\":\"tracking\",\"part\":\"parse\",\"datagram_bytes\":%zu,\"lines_per_datagram\":%.1f,"
                "\"lines_per_s\":%.0f,\"MB_per_s\":%.1f,\"us_per_datagram\":%.3f,\"us_parse_and_map\":%.3f,\"errors\":%d}\n",
                bytes_per_pass / packets.size(), static_cast<double>(lines_per_pass) / packets.size(), parse_lines,
                parse_mb, parse_us, map_us, errors);
  else
    std::printf("parse: five-finger hand datagrams of %zu bytes, %.0f lines each: %.2f M lines/s, %.0f MB/s, %.2f µs "
                "per datagram (%.2f µs with the mapping to fingertip targets), %d errors (median of %d)\n",
                bytes_per_pass / packets.size(), static_cast<double>(lines_per_pass) / packets.size(),
                parse_lines / 1e6, parse_mb, parse_us, map_us, errors, reps);
  std::fflush(stdout);

  // --- 10,000 datagrams per second into the live loop; the hand stays open above the box
  const double flood_s = opt.quick ? 0.5 : 1.0;
  std::vector<std::string> flood;
  for (int i = 0; i < static_cast<int>(10000 * flood_s); ++i) flood.push_back(hand.Datagram(0.1, static_cast<uint32_t>(i + 1)));
  const LiveRun rx = RunWithSender(flood, 10000.0, flood_s + 0.8);
  if (!rx.ok) return kExitFailure;
  const LiveStats& fs = rx.stats;
  if (opt.json)
    std::printf("{\"bench\":\"tracking\",\"part\":\"receive\",\"sent\":%llu,\"received\":%llu,\"received_hz\":%.0f,"
                "\"parse_errors\":%llu,\"sim_rate_hz\":%.1f,\"overruns\":%lld,\"skipped_steps\":%lld,"
                "\"step_max_ms\":%.3f}\n",
                static_cast<unsigned long long>(rx.sent), static_cast<unsigned long long>(fs.datagrams), fs.tracker_hz,
                static_cast<unsigned long long>(fs.parse.TotalErrors()), fs.sim_rate_hz(),
                static_cast<long long>(fs.overruns), static_cast<long long>(fs.skipped_steps), fs.step_max_ms);
  else
    std::printf("receive: %llu of %llu five-finger datagrams at %.0f Hz received and parsed (%llu parse errors); "
                "simulation %.1f Hz for 1000, %lld overruns, %lld skipped steps, step max %.3f ms\n",
                static_cast<unsigned long long>(fs.datagrams), static_cast<unsigned long long>(rx.sent), fs.tracker_hz,
                static_cast<unsigned long long>(fs.parse.TotalErrors()), fs.sim_rate_hz(),
                static_cast<long long>(fs.overruns), static_cast<long long>(fs.skipped_steps), fs.step_max_ms);
  std::fflush(stdout);

  // --- latency at a tracker's pace: the synthetic grasp, 100 Hz
  const double lat_s = opt.quick ? 1.5 : hand.duration_s;
  std::vector<std::string> grasp;
  hand.fingers = 3;
  for (int i = 0; i < static_cast<int>(100 * lat_s); ++i) grasp.push_back(hand.Datagram(i * 0.01, static_cast<uint32_t>(i + 1)));
  const LiveRun lr = RunWithSender(grasp, 100.0, lat_s + 0.6);
  if (!lr.ok) return kExitFailure;
  const LiveStats& ls = lr.stats;
  std::vector<double> steps(ls.latency_steps.begin(), ls.latency_steps.end());
  const double steps_median = Median(steps), steps_max = steps.empty() ? 0.0 : *std::max_element(steps.begin(), steps.end());
  const double within = steps.empty() ? 0.0
                                      : static_cast<double>(std::count_if(steps.begin(), steps.end(), [](double s) { return s <= 1.0; })) /
                                            static_cast<double>(steps.size());
  const double us_median = Median(ls.latency_us), us_p99 = Quantile(ls.latency_us, 0.99),
               us_max = ls.latency_us.empty() ? 0.0 : *std::max_element(ls.latency_us.begin(), ls.latency_us.end());
  if (opt.json)
    std::printf("{\"bench\":\"tracking\",\"part\":\"latency\",\"samples\":%zu,\"latency_steps_median\":%.0f,"
                "\"latency_steps_max\":%.0f,\"within_one_step\":%.4f,\"latency_us_median\":%.1f,\"latency_us_p99\":%.1f,"
                "\"latency_us_max\":%.1f,\"sim_rate_hz\":%.1f,\"overruns\":%lld}\n",
                steps.size(), steps_median, steps_max, within, us_median, us_p99, us_max, ls.sim_rate_hz(),
                static_cast<long long>(ls.overruns));
  else
    std::printf("latency: %zu datagrams at 100 Hz: arrival to the force it causes: median %.0f step (%.0f µs), max %.0f "
                "steps, %.2f%% within one step; p99 %.0f µs, max %.0f µs; simulation %.1f Hz, %lld overruns\n",
                steps.size(), steps_median, us_median, steps_max, 100.0 * within, us_p99, us_max, ls.sim_rate_hz(),
                static_cast<long long>(ls.overruns));
  const bool ok = steps_median <= 1.0;
  std::printf("{\"bench\":\"tracking\",\"parse_lines_per_s\":%.0f,\"parse_us_per_datagram\":%.3f,\"receive_hz\":%.0f,"
              "\"receive_sim_rate_hz\":%.1f,\"latency_steps\":%.0f,\"latency_steps_max\":%.0f,\"latency_us\":%.1f,"
              "\"target_latency_steps\":1,\"ok\":%s}\n",
              parse_lines, parse_us, fs.tracker_hz, fs.sim_rate_hz(), steps_median, steps_max, us_median,
              ok ? "true" : "false");
  return ok ? kExitOk : kExitFailure;
}

}  // namespace gs::app
