// `graspsim record --port P -o FILE.lcmlog [--duration S]`: writes every DTrack
// datagram received, raw, with its arrival time, to an LCM event log
// (graspsim.dtrack_datagram_t on channel DTRACK_RAW). Ctrl-C stops.
#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <thread>

#include "app/cli_help.h"
#include "app/commands.h"
#include "session/tracker_app.h"
#include "tracking/session_log.h"

namespace gs::app {
namespace {

struct RecordOptions {
  tracking::UdpOptions udp;
  std::string out;
  double duration = 0.0;
  bool quiet = false;
};

int Record(const RecordOptions& opt) {
  std::string error;
  tracking::SessionWriter writer;
  if (!writer.Open(opt.out, &error)) {
    std::fprintf(stderr, "record: %s\n", error.c_str());
    return kExitBadInput;
  }
  tracking::UdpReceiver rx;
  if (!rx.Open(opt.udp, &error)) {
    std::fprintf(stderr, "record: %s\n", error.c_str());
    return kExitBadInput;
  }
  // the receiver thread writes each datagram as it arrives and parses it for the error counts
  std::mutex mu;
  tracking::DTrackParser parser;
  tracking::DTrackFrame frame;
  uint64_t write_errors = 0;
  int64_t first_ns = -1, last_ns = -1;
  rx.Start([&](const tracking::Datagram& d) {
    std::lock_guard<std::mutex> lock(mu);
    if (!writer.Write(d)) ++write_errors;
    if (d.truncated)
      parser.CountOversized(d.size);
    else
      parser.Parse(d.data, d.size, &frame);
    if (first_ns < 0) first_ns = d.monotonic_ns;
    last_ns = d.monotonic_ns;
  });
  std::printf("record: listening on UDP port %d%s%s (receive buffer %d bytes), writing %s (Ctrl-C stops)\n",
              rx.port(), opt.udp.multicast_group.empty() ? "" : ", group ", opt.udp.multicast_group.c_str(),
              rx.receive_buffer_bytes(), opt.out.c_str());
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  const bool tty = StdoutIsTerminal() && !opt.quiet;
  while (!StopRequested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    {
      // every 50 ms what was received goes to the kernel: a SIGKILL loses at most the last 50 ms
      std::lock_guard<std::mutex> lock(mu);
      if (!writer.Flush()) ++write_errors;
    }
    if (opt.duration > 0 && elapsed >= opt.duration) break;
    if (tty) {
      std::lock_guard<std::mutex> lock(mu);
      std::printf("\r  %.1f s  %llu datagrams  %s parse errors   ", elapsed,
                  static_cast<unsigned long long>(writer.written()), FormatParseErrors(parser.stats()).c_str());
      std::fflush(stdout);
    }
  }
  rx.Stop();
  writer.Close();
  if (tty) std::printf("\n");
  const uint64_t n = writer.written();
  const double span = n > 1 ? 1e-9 * static_cast<double>(last_ns - first_ns) : 0.0;
  std::printf("record: %llu datagrams (%.1f Hz) written to %s; parse errors %s; %llu rejected senders; %llu write errors\n",
              static_cast<unsigned long long>(n), span > 0 ? static_cast<double>(n - 1) / span : 0.0, opt.out.c_str(),
              FormatParseErrors(parser.stats()).c_str(),
              static_cast<unsigned long long>(rx.stats().rejected_sender.load()),
              static_cast<unsigned long long>(write_errors));
  // what reached the socket was written; what the kernel dropped on a full buffer never reached it
  std::printf("record: socket received %llu datagrams, the kernel dropped %llu (receive buffer full; raise --rcvbuf)\n",
              static_cast<unsigned long long>(rx.stats().received.load()),
              static_cast<unsigned long long>(rx.stats().kernel_drops.load()));
  if (parser.stats().TotalErrors()) std::printf("record: last parse error: %s\n", parser.last_error());
  return write_errors ? kExitFailure : kExitOk;
}

}  // namespace

void AddRecordCommand(CLI::App& app, int* exit_code) {
  auto opt = std::make_shared<RecordOptions>();
  CLI::App* cmd = app.add_subcommand("record", "Record DTrack UDP datagrams, raw with arrival times, to an LCM log");
  AddUdpReceiveOptions(cmd, &opt->udp);
  cmd->add_option("-o,--out", opt->out, "the LCM event log to write")->type_name("FILE.lcmlog")->required();
  cmd->add_option("--duration", opt->duration, "stop after this many seconds (default: at Ctrl-C)")
      ->type_name("SECONDS")
      ->check(Positive("number of seconds"));
  cmd->add_option("--rcvbuf", opt->udp.socket_buffer_bytes,
                  "socket receive buffer in bytes (default 4 MiB; beyond net.core.rmem_max only as root)")
      ->type_name("BYTES")
      ->check(IntInRange(4096, 1 << 30, "a buffer size in bytes"));
  cmd->add_flag("--quiet", opt->quiet, "no status line");
  SetHelpFooter(cmd,
                {{"graspsim record --port 5000 -o session.lcmlog --duration 5",
                  "five seconds of what arrives on UDP port 5000 (start graspsim send --synthetic --port 5000 in "
                  "another terminal to try it)"},
                 {"graspsim record --port 5000 -o session.lcmlog", "until Ctrl-C, which ends the recording cleanly"}},
                {{kExitOk, "the recording ended (--duration or Ctrl-C) and every datagram received was written"},
                 {kExitFailure, "a datagram could not be written to the log"},
                 {kExitUsage, "bad command line"},
                 {kExitBadInput, "the log cannot be created, or the UDP port cannot be opened"}});
  cmd->callback([opt, exit_code]() { *exit_code = Record(*opt); });
}

}  // namespace gs::app
