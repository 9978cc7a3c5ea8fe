// `graspsim send FILE.lcmlog | --synthetic --port P [--rate HZ]`: sends DTrack
// datagrams over UDP: those of a recorded session at their recorded pace (or
// at --rate), or a synthetic hand that grasps and lifts the paper's box.
#include <chrono>
#include <cstdio>
#include <memory>
#include <thread>

#include "app/cli_help.h"
#include "app/commands.h"
#include "scene/paths.h"
#include "session/tracked_sim.h"
#include "session/tracker_app.h"
#include "tracking/session_log.h"
#include "tracking/synthetic_hand.h"

namespace gs::app {
namespace {

struct SendOptions {
  std::string log;
  bool synthetic = false;
  std::string host = "127.0.0.1";
  int port = 5000;
  double rate = 0.0;  // 0: the log's pace; synthetic default 100
  int fingers = 0;  // 0: 3, or 5 with --whole-hand
  bool whole_hand = false;  // every phalanx and the palm (config/whole_hand_power_grasp.yaml)
  double hold = 3.0;
  bool pinch = false;
  bool left = false;
  int loops = 1;
  double start_delay = 0.0;
  std::string scene;  // --synthetic: the hand of this scene's tracker, aimed at its object
};

// the synthetic hand of the options (--scene: the one that scene's tracker follows,
// aimed at its object); false with the scene's error
bool ChooseHand(const SendOptions& opt, tracking::SyntheticHand* hand, std::string* error) {
  if (!opt.scene.empty()) {
    TrackedSim sim;
    std::string moved;
    if (!LoadForSyntheticHand(ResolveResource(opt.scene), &sim, hand, &moved, error)) return false;
    if (!moved.empty())
      std::printf("send: %s: %s; live starts the hand where the scene puts it: give the scene's hand that pose\n",
                  opt.scene.c_str(), moved.c_str());
    if (hand->whole_hand) {
      hand->hold_s = opt.hold;
      hand->duration_s = 2.8 + opt.hold;
    }
  } else {
    hand->fingers = opt.fingers ? opt.fingers : 3;
    if (opt.whole_hand) *hand = tracking::SyntheticHand::WholeHand(opt.fingers ? opt.fingers : 5, opt.hold);
    hand->right = !opt.left;
  }
  hand->pinch = opt.pinch;
  return true;
}

int Send(const SendOptions& opt) {
  if (!opt.scene.empty() && (!opt.synthetic || opt.whole_hand || opt.fingers || opt.left)) {
    std::fprintf(stderr, "send: --scene chooses the synthetic hand (its tracker's fingers and side): give it with "
                         "--synthetic, without --whole-hand, --fingers or --left\n");
    return kExitUsage;
  }
  if (opt.pinch && !(opt.synthetic && (opt.whole_hand || !opt.scene.empty()))) {
    std::fprintf(stderr, "send: --pinch is a grasp of the synthetic whole hand: give it with --synthetic --whole-hand\n");
    return kExitUsage;
  }
  if (opt.left && !(opt.synthetic && opt.whole_hand)) {
    std::fprintf(stderr, "send: --left is a side of the synthetic whole hand: give it with --synthetic --whole-hand\n");
    return kExitUsage;
  }
  if (opt.synthetic == !opt.log.empty()) {
    std::fprintf(stderr, "send: give either a session log or --synthetic\n");
    return kExitUsage;
  }
  std::string error;
  tracking::UdpSender tx;
  if (!tx.Open(opt.host, opt.port, &error)) {
    std::fprintf(stderr, "send: %s\n", error.c_str());
    return kExitUsage;
  }
  // one pass: the synthetic hand, or the log streamed (sessions can be longer than memory)
  tracking::SyntheticHand hand;
  if (!ChooseHand(opt, &hand, &error)) {
    std::fprintf(stderr, "send: %s\n", error.c_str());
    return kExitBadInput;
  }
  if (opt.pinch && !hand.whole_hand) {
    std::fprintf(stderr, "send: --pinch is a grasp of the whole hand; %s's tracker follows fingertips\n",
                 opt.scene.c_str());
    return kExitUsage;
  }
  const double synthetic_rate = opt.rate > 0 ? opt.rate : 100.0;
  uint64_t per_pass = 0;
  double period = 0.0;  // seconds from one pass's start to the next
  if (opt.synthetic) {
    per_pass = static_cast<uint64_t>(hand.duration_s * synthetic_rate) + 1;
    period = static_cast<double>(per_pass) / synthetic_rate;
  } else {
    tracking::SessionSummary summary;
    if (!tracking::ScanSession(opt.log, &summary, &error)) {
      std::fprintf(stderr, "send: %s\n", error.c_str());
      return kExitBadInput;
    }
    if (summary.datagrams == 0) {
      std::fprintf(stderr, "send: %s holds no datagrams on %s\n", opt.log.c_str(), tracking::kRawChannel);
      return kExitBadInput;
    }
    per_pass = summary.datagrams;
    const double span = 1e-6 * static_cast<double>(summary.last_monotonic_utime - summary.first_monotonic_utime);
    period = opt.rate > 0 ? static_cast<double>(per_pass) / opt.rate
                          : span + (per_pass > 1 ? span / static_cast<double>(per_pass - 1) : 0.01);
  }
  std::printf("send: %llu datagrams per pass (%.2f s) to %s:%d, %d pass%s\n", static_cast<unsigned long long>(per_pass),
              period, opt.host.c_str(), opt.port, opt.loops, opt.loops == 1 ? "" : "es");
  std::fflush(stdout);
  if (opt.start_delay > 0) std::this_thread::sleep_for(std::chrono::duration<double>(opt.start_delay));
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  uint64_t sent = 0;
  // absolute deadlines: no drift over a long session
  auto send_at = [&](double t, const std::string& bytes) {
    std::this_thread::sleep_until(t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t)));
    if (!StopRequested() && tx.Send(bytes.data(), bytes.size())) ++sent;
  };
  for (int pass = 0; pass < opt.loops && !StopRequested(); ++pass) {
    const double base = pass * period;
    if (opt.synthetic) {
      for (uint64_t i = 0; i < per_pass && !StopRequested(); ++i) {
        const double t = static_cast<double>(i) / synthetic_rate;
        send_at(base + t, hand.Datagram(t, static_cast<uint32_t>(pass * per_pass + i + 1)));
      }
      continue;
    }
    tracking::SessionReader reader;
    if (!reader.Open(opt.log, &error)) {
      std::fprintf(stderr, "send: %s\n", error.c_str());
      return kExitBadInput;
    }
    tracking::RecordedDatagram d;
    int64_t first = 0;
    for (uint64_t i = 0; reader.Next(&d) && !StopRequested(); ++i) {
      if (i == 0) first = d.monotonic_utime;
      const double t = opt.rate > 0 ? static_cast<double>(i) / opt.rate : 1e-6 * static_cast<double>(d.monotonic_utime - first);
      send_at(base + t, d.data);
    }
    if (!reader.error().empty()) {
      std::fprintf(stderr, "send: %s\n", reader.error().c_str());
      return kExitBadInput;
    }
  }
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf("send: %llu datagrams in %.2f s (%.1f Hz), %llu send errors\n", static_cast<unsigned long long>(sent),
              wall, sent > 1 && wall > 0 ? static_cast<double>(sent - 1) / wall : 0.0,
              static_cast<unsigned long long>(tx.errors()));
  return tx.errors() ? kExitFailure : kExitOk;
}

}  // namespace

void AddSendCommand(CLI::App& app, int* exit_code) {
  auto opt = std::make_shared<SendOptions>();
  CLI::App* cmd = app.add_subcommand("send", "Send DTrack datagrams over UDP: a recorded session or a synthetic hand");
  cmd->add_option("log", opt->log, "session log to send at its recorded pace (or --synthetic)")
      ->type_name("FILE.lcmlog");
  cmd->add_flag("--synthetic", opt->synthetic, "a synthetic hand that grasps, lifts and releases the paper's box");
  cmd->add_option("--port", opt->port, "destination UDP port")
      ->type_name("PORT")
      ->required()
      ->check(IntInRange(1, 65535, "a UDP port"));
  cmd->add_option("--host", opt->host, "destination IPv4 address")->type_name("ADDRESS")->capture_default_str();
  cmd->add_option("--rate", opt->rate, "datagrams per second (synthetic default 100; a log: its recorded pace)")
      ->type_name("HZ")
      ->check(InRange(0.1, 100000.0, "a rate in datagrams per second"));
  cmd->add_option("--fingers", opt->fingers, "synthetic hand's fingers (default 3; 5 with --whole-hand)")
      ->type_name("3|5")
      ->check(OneOf({"3", "5"}, "a finger count"));
  cmd->add_flag("--whole-hand", opt->whole_hand,
                "synthetic: a whole hand (palm and every phalanx, consistent gl blocks) in a power grasp of the box "
                "(config/whole_hand_power_grasp.yaml); with --fingers 5 (or 3: thumb, index, middle)");
  cmd->add_flag("--pinch", opt->pinch,
                "--whole-hand: a precision pinch, the thumb's and the index's outer phalanges on two faces "
                "(config/tracked_whole_hand.yaml)");
  cmd->add_flag("--left", opt->left,
                "--whole-hand: a left hand (gl's lr 0), the right one mirrored, for a scene's hand with side: left");
  cmd->add_option("--hold", opt->hold, "--whole-hand: seconds the box is held lifted")
      ->type_name("SECONDS")
      ->capture_default_str()
      ->check(InRange(0.0, 600.0, "a number of seconds"));
  cmd->add_option("--scene", opt->scene,
                  "--synthetic: the hand that scene's tracker follows (fingertips or a whole hand, its fingers and "
                  "side), grasping the scene's object where it lies: a box on its faces, a curved one wrapped, a tall "
                  "curved one from the side (docs/tracking.md)")
      ->type_name("SCENE.yaml");
  cmd->add_option("--loop", opt->loops, "passes over the session")
      ->type_name("N")
      ->check(IntInRange(1, 1000000, "a number of passes"));
  cmd->add_option("--delay", opt->start_delay, "seconds to wait before the first datagram")
      ->type_name("SECONDS")
      ->check(InRange(0.0, 60.0, "a number of seconds"));
  SetHelpFooter(cmd,
                {{"graspsim send --synthetic --port 5000", "the synthetic grasp at 100 Hz to 127.0.0.1:5000 (the "
                                                           "port of config/tracked_hand.yaml)"},
                 {"graspsim send --synthetic --whole-hand --fingers 5 --port 5000",
                  "a five-finger whole hand grasping the box with palm and phalanges (5.8 s)"},
                 {"graspsim send --synthetic --scene my_can.yaml --port 5000",
                  "the hand my_can.yaml's tracker follows, grasping its object"},
                 {"graspsim send assets/demo_session.lcmlog --port 5000 --loop 3",
                  "a recorded session, three times at its recorded pace"}},
                {{kExitOk, "every datagram was sent"},
                 {kExitFailure, "a datagram could not be sent"},
                 {kExitUsage, "bad command line: neither or both of FILE.lcmlog and --synthetic, --pinch or --left "
                              "without --synthetic --whole-hand, --scene with --whole-hand, --fingers or --left, or a "
                              "--host that cannot be used"},
                 {kExitBadInput, "the session log was refused or holds no datagrams, or the --scene was refused"},
                 {kExitInterrupted, "stopped early by Ctrl-C or SIGTERM"}});
  cmd->callback([opt, exit_code]() { *exit_code = Send(*opt); });
}

}  // namespace gs::app
