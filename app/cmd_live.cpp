// `graspsim live [SCENE]`: the fixed-rate simulation (the scene's timestep,
// 1 kHz by default) on live DTrack input, publishing fingertip and object
// poses and every contact force on LCM, with a status line. Ctrl-C stops.
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <memory>
#include <mutex>

#include "app/cli_help.h"
#include "app/commands.h"
#include "session/live_loop.h"
#include "scene/paths.h"
#include "session/frame_recorder.h"
#include "session/tracker_app.h"
#include "tracking/lcm_receiver.h"
#include "tracking/session_log.h"
#include "view/live_view.h"

namespace gs::app {
namespace {

struct LiveCmd {
  std::string scene = "config/tracked_hand.yaml";
  int port = -1;
  std::string multicast, controller;
  std::vector<std::string> allow;
  double duration = 0.0;
  double publish_rate = -1.0;
  std::string lcm_url;
  std::string tracker = "udp";  ///< udp, or lcm[:CHANNEL]
  bool quiet = false;
  RenderOptions render;  ///< --frames, --video, ... (docs/render.md)
  std::string view;      ///< --view [ADDR:]PORT: the live view (view/live_view.h)
  int rt_priority = 50;  ///< SCHED_FIFO priority of the simulation thread (0: normal)
  int cpu = 0;           ///< the simulation thread's core (-1: anywhere)
  bool cpu_given = false;  ///< --cpu on the command line: that core, even when another loop has it
  double step_budget = 0.8;  ///< a step has this fraction of the timestep, ending at most as far into its slot (0: no limit)
  int lead_steps = 1;        ///< a step may begin this many timesteps before its slot
  bool skip_late_solves = false;
  bool detect_every_step = false;
  int threads = 0;  ///< --threads (0: WorkerPool::ThreadsFor's default)
};

// live's input: the scene's tracker section, overridden by the command line
void InputOptions(const LiveCmd& c, const tracking::TrackerConfig& tc, LiveOptions* o) {
  o->udp.port = c.port >= 0 ? c.port : tc.port;
  o->udp.multicast_group = c.multicast.empty() ? tc.multicast_group : c.multicast;
  o->udp.allowed_senders = c.allow.empty() ? tc.allowed_senders : c.allow;
  o->udp.controller = c.controller.empty() ? tc.controller : c.controller;
  o->lcm_url = c.lcm_url.empty() ? tc.lcm_url : c.lcm_url;
  if (c.tracker != "udp") o->lcm_channel = c.tracker.size() > 4 ? c.tracker.substr(4) : tracking::kRawChannel;
}

// `sizes: tracker`: live's input is opened before the scene is built and hands
// its datagrams to the sizing one by one until one sizes the hand; Ctrl-C ends the
// wait. Destroyed (the socket closed) before the live loop opens its own.
class SizingWait {
 public:
  explicit SizingWait(const LiveCmd& c) : cmd_(c) {}
  ~SizingWait() {
    if (source_) source_->Stop();
  }
  const std::string& error() const { return error_; }
  /// The UDP port the wait listened on (0: none, or LCM).
  int udp_port() const {
    const auto* udp = dynamic_cast<const tracking::UdpReceiver*>(source_.get());
    return udp ? udp->port() : 0;
  }

  bool Next(const tracking::TrackerConfig& tc, std::string* data) {
    if (!source_ && !Open(tc)) return false;
    std::unique_lock<std::mutex> lock(mutex_);
    auto last_note = std::chrono::steady_clock::now();
    while (queue_.empty()) {
      if (StopRequested()) return false;
      arrived_.wait_for(lock, std::chrono::milliseconds(100));
      // a status line now and then, so that a silent or unusable tracker is visible
      if (std::chrono::steady_clock::now() - last_note > std::chrono::seconds(5) && queue_.empty()) {
        std::printf("live: still waiting to size the hand: %llu datagrams so far, none usable yet\n",
                    static_cast<unsigned long long>(received_));
        std::fflush(stdout);
        last_note = std::chrono::steady_clock::now();
      }
    }
    *data = std::move(queue_.front());
    queue_.pop_front();
    return true;
  }

 private:
  bool Open(const tracking::TrackerConfig& tc) {
    LiveOptions o;
    InputOptions(cmd_, tc, &o);
    source_ = OpenLiveSource(o, &error_);
    if (!source_) return false;
    source_->Start([this](const tracking::Datagram& d) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++received_;
      // the sizing reads far slower than a tracker may send: a few waiting are enough
      if (d.truncated || queue_.size() >= 16) return;
      queue_.emplace_back(d.data, d.size);
      arrived_.notify_one();
    });
    std::printf("live: waiting for the tracker's hand %d on %s to size the hand (sizes: tracker) ... (Ctrl-C stops)\n",
                tc.hand_id, source_->Describe().c_str());
    std::fflush(stdout);
    return true;
  }

  const LiveCmd& cmd_;
  std::unique_ptr<tracking::DatagramSource> source_;
  std::string error_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<std::string> queue_;
  uint64_t received_ = 0;
};

// loads the scene, a `sizes: tracker` hand sized from the first usable datagram
// (*sized_port: the UDP port the sizing listened on, which the loop keeps when the
// command line asked for any free port: the tracker was told that one)
int LoadLiveScene(const LiveCmd& c, TrackedSim* sim, int* sized_port) {
  SizingWait wait(c);
  std::string error;
  const SizingFeed feed = [&wait](const tracking::TrackerConfig& tc, std::string* d) { return wait.Next(tc, d); };
  if (sim->Load(ResolveResource(c.scene), &error, feed)) {
    if (!sim->sizing_note().empty()) std::printf("live: %s\n", sim->sizing_note().c_str());
    *sized_port = wait.udp_port();
    return kExitOk;
  }
  if (!wait.error().empty()) {
    std::fprintf(stderr, "live: %s\n", wait.error().c_str());
    return kExitBadInput;
  }
  if (StopRequested()) {
    std::printf("live: interrupted while waiting for the tracker to size the hand\n");
    return kExitInterrupted;
  }
  std::fprintf(stderr, "%s\n", error.c_str());
  return kExitBadInput;
}

int Live(const LiveCmd& c) {
  auto sim = std::make_unique<TrackedSim>();
  std::string error;
  if (!CheckRenderOptions(c.render, &error)) {  // before the scene is built
    std::fprintf(stderr, "live: %s\n", error.c_str());
    return kExitUsage;
  }
  int sized_port = 0;
  if (const int code = LoadLiveScene(c, sim.get(), &sized_port); code != kExitOk) return code;
  // the scene's tracker section, overridden by the command line
  const tracking::TrackerConfig& tc = sim->config();
  LiveOptions o;
  InputOptions(c, tc, &o);
  if (o.lcm_channel.empty() && o.udp.port == 0 && sized_port > 0) o.udp.port = sized_port;
  o.duration = c.duration;
  o.publish_rate = c.publish_rate >= 0 ? c.publish_rate : tc.publish_rate_hz;
  o.quiet = c.quiet;
  o.pacing.priority = c.rt_priority;
  std::string moved;
  o.pacing.cpu = c.cpu_given ? c.cpu : ChooseCore(c.cpu, &moved);
  o.step_budget = c.step_budget;
  o.lead_steps = c.lead_steps;
  o.skip_late_solves = c.skip_late_solves;
  o.detect_every_step = c.detect_every_step;
  o.threads = WorkerPool::ThreadsFor(c.threads);
  const World& w = sim->world();
  char lcm[300];
  if (o.publish_rate > 0)
    std::snprintf(lcm, sizeof(lcm), "LCM %s at %g Hz", o.lcm_url.empty() ? "default URL" : o.lcm_url.c_str(),
                  o.publish_rate);
  else
    std::snprintf(lcm, sizeof(lcm), "LCM publishing off");
  const std::string input = o.lcm_channel.empty()
                                ? "UDP port " + std::to_string(o.udp.port) +
                                      (o.udp.multicast_group.empty() ? "" : " group " + o.udp.multicast_group)
                                : "LCM channel " + o.lcm_channel;
  std::printf("live: scene %s, %zu bodies, %zu tracked fingertips; %.0f Hz simulation; %s; %s (Ctrl-C stops)\n",
              sim->scene().name.c_str(), w.bodies.size(), tc.fingertips.size(), 1.0 / w.params.dt, input.c_str(), lcm);
  if (!moved.empty()) std::printf("live: %s\n", moved.c_str());
  std::fflush(stdout);
  // a render thread fed from a fixed pool of snapshots: never waited for
  FrameRecorder recorder;
  RenderOptions ro = c.render;
  ro.avoid_cpu = o.pacing.cpu;  // rendering on the other core(s)
  view::LiveView live_view;  // reads the recorder's snapshots on the render thread
  if (!c.view.empty() && !live_view.Start(c.view, sim->scene(), &error, o.pacing.cpu)) {
    std::fprintf(stderr, "live: %s\n", error.c_str());
    return kExitUsage;
  }
  if (!c.view.empty()) ro.reader = &live_view;
  if (!recorder.Start(ro, sim->scene(), &error, ERecordMode::Live)) {
    std::fprintf(stderr, "live: %s\n", error.c_str());
    return kExitUsage;
  }
  LiveStats st;
  if (!RunLive(*sim, o, &st, &error, &recorder)) {
    std::fprintf(stderr, "live: %s\n", error.c_str());
    return kExitBadInput;
  }
  const bool rendering = recorder.active();
  if (rendering) {
    if (!recorder.Finish(&error)) {
      std::fprintf(stderr, "live: %s\n", error.c_str());
      return kExitFailure;
    }
    st.frames_drawn = recorder.frames_drawn();
  }
  if (!c.view.empty()) live_view.Stop();
  std::printf("live: %.2f s wall, %lld steps (%.1f Hz for %.0f Hz asked), %lld overruns (%.2f%%), %lld skipped; step "
              "median %.3f ms, p99 %.3f ms, max %.3f ms\n",
              st.wall_s, static_cast<long long>(st.steps), st.sim_rate_hz(), 1.0 / w.params.dt,
              static_cast<long long>(st.overruns), st.steps ? 100.0 * st.overruns / st.steps : 0.0,
              static_cast<long long>(st.skipped_steps), st.step_median_ms, st.step_p99_ms, st.step_max_ms);
  std::printf("live: solver: %lld steps unconverged, %lld of them stopped by the step budget (%s), %lld with no time "
              "left for a sweep (the last forces kept); largest error %.3g\n",
              static_cast<long long>(st.unconverged_steps), static_cast<long long>(st.budget_stops),
              o.step_budget > 0 ? (std::to_string(o.step_budget) + " of a timestep").c_str() : "off",
              static_cast<long long>(st.skipped_solves), st.residual_max);
  std::printf("live: %lld steps carried the last step's contacts after steps past their budget (%s)\n",
              static_cast<long long>(st.carried_steps),
              o.detect_every_step || o.step_budget <= 0 ? "off: detection in every step" : "--detect-every-step turns it off");
  std::printf("live: simulation thread: %s%s%s; a step may begin %d timestep%s before its slot (--lead-steps)\n",
              st.pacing.Describe().c_str(), st.pacing.refused.empty() ? "" : "; ", st.pacing.refused.c_str(),
              o.lead_steps, o.lead_steps == 1 ? "" : "s");
  std::printf("live: tracker %.2f Hz received (%llu datagrams, %llu applied, the rest stale), parse errors %s, %llu "
              "rejected senders; %llu LCM messages published\n",
              st.tracker_hz, static_cast<unsigned long long>(st.datagrams),
              static_cast<unsigned long long>(st.samples_applied), FormatParseErrors(st.parse).c_str(),
              static_cast<unsigned long long>(st.rejected_senders), static_cast<unsigned long long>(st.published));
  if (st.parse.TotalErrors()) std::printf("live: last parse error: %s\n", st.last_parse_error.c_str());
  std::printf("live: good datagrams (carrying %s, tracked): %llu of %llu, %.2f Hz; %llu not DTrack, %llu without %s%s\n",
              st.needs.c_str(), static_cast<unsigned long long>(st.good_datagrams),
              static_cast<unsigned long long>(st.datagrams), st.good_hz, static_cast<unsigned long long>(st.not_dtrack),
              static_cast<unsigned long long>(st.missing), st.needs.c_str(),
              st.foreign_messages ? ("; " + std::to_string(st.foreign_messages) +
                                     " LCM messages of another type on the channel").c_str()
                                  : "");
  // the same judgement as replay's: input that never drove the scene is said, with what to change
  const std::string undriven = NothingDrivenText(st.Tally(), sim->config());
  if (!undriven.empty()) std::fprintf(stderr, "live: %s\n", undriven.c_str());
  if (sim->scene().tracked_body >= 0)
    std::printf("live: %s highest rise %.2f mm%s; up to %d contacts\n",
                w.bodies[sim->scene().tracked_body].name.c_str(), 1e3 * st.max_rise_m,
                st.max_rise_m >= 0.02 ? ": grasped and lifted" : "", st.max_contacts);
  const tracking::HealthCounts& h = st.health;
  std::printf("live: tracker events: %d silences, %d recoveries, %d rate changes, %d garbage bursts, %d floods, %d "
              "bursts from senders outside the allow list, %d bursts of datagrams that are not DTrack, %d of datagrams "
              "without %s; "
              "tracker %s at the end\n",
              h.silences, h.recoveries, h.rate_changes, h.garbage_bursts, h.floods, h.rejected_bursts,
              h.not_dtrack_bursts, h.missing_bursts, st.needs.c_str(), st.tracker_state.c_str());
  std::printf("{\"live\":true,\"wall_s\":%.6f,\"steps\":%lld,\"sim_rate_hz\":%.3f,\"target_rate_hz\":%.3f,"
              "\"overruns\":%lld,\"skipped_steps\":%lld,\"step_median_ms\":%.4f,\"step_max_ms\":%.4f,"
              "\"datagrams\":%llu,\"tracker_hz\":%.4f,\"parse_errors\":%llu,\"rejected_senders\":%llu,"
              "\"silences\":%d,\"recoveries\":%d,\"rate_changes\":%d,\"garbage_bursts\":%d,\"floods\":%d,"
              "\"rejected_bursts\":%d,\"tracker_state\":\"%s\",\"published\":%llu,\"lcm_ok\":%s,"
              "\"rendering\":%s,\"frames_drawn\":%lld,\"frames_dropped\":%lld,\"pacing\":\"%s\","
              "\"unconverged_steps\":%lld,\"budget_stops\":%lld,\"skipped_solves\":%lld,\"carried_contact_steps\":%lld,"
              "\"residual_max\":%.3g,"
              "\"lead_steps\":%d,\"tracker_input\":\"%s\",\"good_datagrams\":%llu,\"good_hz\":%.4f,"
              "\"not_dtrack_datagrams\":%llu,\"missing_datagrams\":%llu,\"not_dtrack_bursts\":%d,"
              "\"missing_bursts\":%d,\"foreign_messages\":%llu,\"max_rise_m\":%.6f,\"lifted\":%s,"
              "\"max_contacts\":%d}\n",
              st.wall_s, static_cast<long long>(st.steps), st.sim_rate_hz(), 1.0 / w.params.dt,
              static_cast<long long>(st.overruns), static_cast<long long>(st.skipped_steps), st.step_median_ms,
              st.step_max_ms, static_cast<unsigned long long>(st.datagrams), st.tracker_hz,
              static_cast<unsigned long long>(st.parse.TotalErrors()), static_cast<unsigned long long>(st.rejected_senders),
              h.silences, h.recoveries, h.rate_changes, h.garbage_bursts, h.floods, h.rejected_bursts,
              st.tracker_state.c_str(), static_cast<unsigned long long>(st.published),
              st.lcm_ok ? "true" : "false", rendering ? "true" : "false", static_cast<long long>(st.frames_drawn),
              static_cast<long long>(st.frames_dropped), st.pacing.Describe().c_str(),
              static_cast<long long>(st.unconverged_steps), static_cast<long long>(st.budget_stops),
              static_cast<long long>(st.skipped_solves), static_cast<long long>(st.carried_steps), st.residual_max,
              o.lead_steps,
              o.lcm_channel.empty() ? "udp" : ("lcm:" + o.lcm_channel).c_str(),
              static_cast<unsigned long long>(st.good_datagrams), st.good_hz,
              static_cast<unsigned long long>(st.not_dtrack), static_cast<unsigned long long>(st.missing),
              h.not_dtrack_bursts, h.missing_bursts, static_cast<unsigned long long>(st.foreign_messages),
              st.max_rise_m, st.max_rise_m >= 0.02 ? "true" : "false", st.max_contacts);
  return kExitOk;
}

}  // namespace

void AddLiveCommand(CLI::App& app, int* exit_code) {
  auto c = std::make_shared<LiveCmd>();
  CLI::App* cmd = app.add_subcommand("live", "Run the fixed-rate simulation on live DTrack input, publishing on LCM");
  cmd->add_option("scene", c->scene, "a scene with a tracker section (docs/tracking.md)")
      ->type_name("SCENE.yaml")
      ->capture_default_str();
  cmd->add_option("--port", c->port, "UDP port (default: the scene's tracker.port)")
      ->type_name("PORT")
      ->check(IntInRange(0, 65535, "a UDP port"));
  cmd->add_option("--multicast", c->multicast, "join this multicast group")->type_name("GROUP");
  cmd->add_option("--allow", c->allow, "accept datagrams only from these IPv4 addresses")->type_name("ADDRESS");
  cmd->add_option("--controller", c->controller, "send the DTrack firewall nudge to this Controller (UDP 50107)")
      ->type_name("ADDRESS");
  cmd->add_option("--duration", c->duration, "stop after this many seconds (default: at Ctrl-C)")
      ->type_name("SECONDS")
      ->check(Positive("number of seconds"));
  cmd->add_option("--publish-rate", c->publish_rate, "LCM poses and contacts per second (0: none; default: the scene's)")
      ->type_name("HZ")
      ->check(InRange(0.0, 1e5, "a rate in messages per second"));
  cmd->add_option("--lcm-url", c->lcm_url,
                  "LCM URL for publishing and for --tracker lcm (default: the scene's, else LCM's default udpm)")
      ->type_name("URL");
  cmd->add_option("--tracker", c->tracker,
                  "where the DTrack datagrams come from: udp (the port) or lcm[:CHANNEL] (graspsim.dtrack_datagram_t "
                  "messages at --lcm-url, from lcm-logplayer or graspsim bridge; default channel DTRACK_RAW)")
      ->type_name("udp|lcm[:CHANNEL]")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            if (v == "udp" || v == "lcm") return "";
            if (v.rfind("lcm:", 0) == 0) {
              const std::string bad = tracking::CheckLcmChannel(v.substr(4));
              return bad.empty() ? "" : v + ": " + bad;
            }
            return "'" + v + "' is not a tracker input: udp, lcm or lcm:CHANNEL";
          },
          "", ""))
      ->capture_default_str();
  cmd->add_flag("--quiet", c->quiet, "no status line");
  AddThreadsOption(cmd, &c->threads);
  cmd->add_option("--rt-priority", c->rt_priority,
                  "SCHED_FIFO priority of the simulation thread, 0 for normal scheduling (needs CAP_SYS_NICE; a "
                  "refusal is said and live goes on)")
      ->type_name("N")
      ->check(IntInRange(0, 99, "a SCHED_FIFO priority"))
      ->capture_default_str();
  cmd->add_flag("--detect-every-step", c->detect_every_step,
               "detect collisions in every step; without it, a step that follows one past its step budget carries "
               "that step's contacts, moved with the bodies, instead of detecting them (never two steps in a row)");
  cmd->add_flag("--skip-late-solves", c->skip_late_solves,
               "a step whose stages before the solve left no time for a sweep keeps the last forces instead of "
               "sweeping late (never two steps in a row, never with over 5 % new contacts)");
  cmd->add_option("--step-budget", c->step_budget,
                  "each step has this fraction of the timestep and ends at most as far into its slot: the solver "
                  "stops sweeping early, and the step is counted as a budget stop (0: no limit)")
      ->type_name("FRACTION")
      ->check(InRange(0.0, 10.0, "a fraction of the timestep"))
      ->capture_default_str();
  cmd->add_option("--lead-steps", c->lead_steps,
                  "a step may begin this many timesteps before its own slot, so that a long step uses what the "
                  "steps before it left over (deadlines unchanged: step k ends by (k+1) dt; 0: each step has its "
                  "slot only)")
      ->type_name("N")
      ->check(IntInRange(0, 10, "a whole number of timesteps"))
      ->capture_default_str();
  CLI::Option* cpu = cmd->add_option("--cpu", c->cpu,
                                     "the simulation thread's core; rendering runs on the others (-1: anywhere; "
                                     "without --cpu, the lowest core no other graspsim loop runs on, from 0)")
                         ->type_name("CORE")
                         ->check(IntInRange(-1, 1023, "a core number"))
                         ->capture_default_str();
  AddRenderOptions(cmd, &c->render);
  cmd->add_option("--view", c->view, "serve the live view (a page drawing the grasp in a browser) on this port, "
                  "on every interface unless an address is given (docs/render.md)")
      ->type_name("[ADDR:]PORT");
  SetHelpFooter(cmd,
                {{"graspsim live config/tracked_hand.yaml --duration 10",
                  "ten seconds at 1 kHz on UDP port 5000; once it prints 'live: listening on UDP port 5000', run "
                  "graspsim send --synthetic --port 5000 in another terminal"},
                 {"graspsim live --video live.mp4 --lcm-url 'file:///tmp/live.lcmlog?mode=w'",
                  "until Ctrl-C, with a video and the LCM messages written to a log file"},
                 {"graspsim live --tracker lcm --duration 5",
                  "DTrack datagrams from LCM channel DTRACK_RAW: once it prints 'live: listening on LCM channel', run "
                  "lcm-logplayer assets/demo_session.lcmlog (or graspsim bridge on the tracker's host)"},
                 {"graspsim live --view 8080", "with the live view at http://THIS-HOST:8080/ in any browser"}},
                {{kExitOk, "the session ended (--duration or Ctrl-C) and its summary is printed"},
                 {kExitFailure, "the video could not be finished"},
                 {kExitUsage, "bad command line, or a render option that cannot be met"},
                 {kExitBadInput, "the scene was refused (or has no tracker section), the UDP port cannot be "
                                 "opened, or (--tracker lcm) LCM is unavailable at the URL"}});
  cmd->callback([c, cpu, exit_code]() {
    c->cpu_given = cpu->count() > 0;
    *exit_code = Live(*c);
  });
}

}  // namespace gs::app
