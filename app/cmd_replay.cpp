// `graspsim replay [SCENE] FILE.lcmlog [--out DIR] [--realtime]`: replays a
// recorded tracker session headless. Each datagram applies at its recorded
// arrival time in simulated time (the first at t = 0), so the same log and
// scene give bit-identical outputs on every run, at any speed.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <thread>

#include "app/cli_help.h"
#include "app/commands.h"
#include "scene/paths.h"
#include "session/frame_recorder.h"
#include "session/tracked_sim.h"
#include "session/run_report.h"
#include "session/tracker_app.h"
#include "tracking/hand_mapping.h"
#include "tracking/session_log.h"
#include "view/live_view.h"

namespace gs::app {
namespace {

// what the session's datagrams carried for the scene, as live says it
std::string ReplayTallyText(const TrackedSim& sim) {
  const tracking::TrackerConfig& c = sim.config();
  return TallyText(sim.tally(), tracking::NeedsLabel(c), tracking::MissingLabel(c, sim.tally().missing_code));
}

struct ReplayOptions {
  std::vector<std::string> args;  // [SCENE] LOG
  std::string out;
  double duration = 0.0;
  double tail = 0.5;
  bool realtime = false;
  bool quiet = false;
  bool json = false;  ///< stdout: summary.json's object as one line, nothing else
  RenderOptions render;  ///< --frames, --video, ... (docs/render.md): frames at fixed simulated times
  std::string view;      ///< --view [ADDR:]PORT: the live view (view/live_view.h)
  int threads = 0;       ///< --threads (0: WorkerPool::ThreadsFor's default)
};

void Row(std::ostream& o, double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), ",%.17g", v);
  o << buf;
}

// The output files of --out, written as the replay goes (an interrupted replay
// keeps every row it made); without --out the streams discard what they get.
struct ReplayFiles {
  std::unique_ptr<std::ostream> traj, contacts, tips, frames;
  bool Open(const std::string& dir, std::string* error) {
    auto open = [&](const char* name) -> std::unique_ptr<std::ostream> {
      if (dir.empty()) return std::make_unique<std::ostream>(nullptr);
      return std::make_unique<std::ofstream>(std::filesystem::path(dir) / name, std::ios::binary);
    };
    traj = open("trajectory.csv");
    contacts = open("contacts.csv");
    tips = open("fingertips.csv");
    frames = open("tracker.csv");
    if (!dir.empty() && (!*traj || !*contacts || !*tips || !*frames)) {
      *error = "--out " + dir + ": cannot write trajectory.csv, contacts.csv, fingertips.csv and tracker.csv there";
      return false;
    }
    return true;
  }
  bool Close(const std::string& dir, std::string* error) {
    if (dir.empty()) return true;
    for (auto* f : {traj.get(), contacts.get(), tips.get(), frames.get()}) {
      auto* file = static_cast<std::ofstream*>(f);
      file->close();
      if (file->fail()) {
        *error = "--out " + dir + ": cannot write trajectory.csv, contacts.csv, fingertips.csv or tracker.csv";
        return false;
      }
    }
    return true;
  }
};

int Replay(const ReplayOptions& opt) {
  std::string scene_path = "config/tracked_hand.yaml", log_path;
  if (opt.args.size() == 1) {
    log_path = opt.args[0];
  } else if (opt.args.size() == 2) {
    scene_path = opt.args[0];
    log_path = opt.args[1];
  } else {
    std::fprintf(stderr, "replay: give [SCENE] FILE.lcmlog\n");
    return kExitUsage;
  }
  std::string error;
  // the outputs are checked before any work
  if ((!opt.out.empty() && !CheckOutputFolder("--out", opt.out, &error)) || !CheckRenderOptions(opt.render, &error)) {
    std::fprintf(stderr, "replay: %s\n", error.c_str());
    return kExitUsage;
  }
  // a first pass finds the session's span; the replay then streams the log
  tracking::SessionSummary summary;
  if (!tracking::ScanSession(log_path, &summary, &error)) {
    std::fprintf(stderr, "replay: %s\n", error.c_str());
    return kExitBadInput;
  }
  if (summary.datagrams == 0) {
    std::fprintf(stderr, "replay: %s: no datagrams on channel %s (%llu events on other channels)\n", log_path.c_str(),
                 tracking::kRawChannel, static_cast<unsigned long long>(summary.stats.other_channels));
    return kExitBadInput;
  }
  if (summary.stats.trailing_bytes)
    std::fprintf(stderr,
                 "replay: warning: %s ends with %llu bytes of an incomplete event (the recording was cut short); "
                 "replaying the %llu whole datagrams before it\n",
                 log_path.c_str(), static_cast<unsigned long long>(summary.stats.trailing_bytes),
                 static_cast<unsigned long long>(summary.datagrams));
  tracking::SessionReader reader;
  if (!reader.Open(log_path, &error)) {
    std::fprintf(stderr, "replay: %s\n", error.c_str());
    return kExitBadInput;
  }
  auto sim = std::make_unique<TrackedSim>();
  if (!opt.quiet && !opt.json) std::printf("replay: building scene %s ...\n", ResolveResource(scene_path).c_str());
  // a hand with `sizes: tracker` takes its sizes from the session's first datagram that has them
  // (the session is opened only then: every other scene gives its own errors first, as
  // every command that builds it does)
  tracking::SessionReader sizing_reader;
  std::string log_error;
  bool opened = false;
  SizingFeed sizing = [&](const tracking::TrackerConfig&, std::string* data) {
    if (!opened && !(opened = sizing_reader.Open(log_path, &log_error))) return false;
    tracking::RecordedDatagram sd;
    if (!sizing_reader.Next(&sd)) return false;
    *data = std::move(sd.data);
    return true;
  };
  if (!sim->Load(ResolveResource(scene_path), &error, sizing)) {
    std::fprintf(stderr, "%s\n", log_error.empty() ? error.c_str() : ("replay: " + log_error).c_str());
    return kExitBadInput;
  }
  if (!sim->sizing_note().empty() && !opt.json) std::printf("replay: %s\n", sim->sizing_note().c_str());
  sim->UseThreads(WorkerPool::ThreadsFor(opt.threads));
  World& w = sim->world();
  const double dt = w.params.dt;
  auto arrival = [&](const tracking::RecordedDatagram& d) {
    return 1e-6 * static_cast<double>(d.monotonic_utime - summary.first_monotonic_utime);
  };
  const double span = 1e-6 * static_cast<double>(summary.last_monotonic_utime - summary.first_monotonic_utime);
  const double duration = opt.duration > 0 ? opt.duration : span + opt.tail;
  const int64_t steps = static_cast<int64_t>(std::ceil(duration / dt - 1e-9));
  if (!opt.json)
    std::printf("replay: %s in scene %s: %zu datagrams over %.3f s; simulating %.3f s (%lld steps)\n",
                log_path.c_str(), sim->scene().name.c_str(), static_cast<size_t>(summary.datagrams), span, duration,
                static_cast<long long>(steps));

  // outputs: everything deterministic (no wall times)
  ReplayFiles files;
  if (!files.Open(opt.out, &error)) {
    std::fprintf(stderr, "replay: %s\n", error.c_str());
    return kExitFailure;
  }
  std::ostream& traj = *files.traj;
  std::ostream& contacts = *files.contacts;
  std::ostream& tips = *files.tips;
  std::ostream& frames = *files.frames;
  WriteTrajectoryHeader(traj, w);
  WriteContactsHeader(contacts);
  const auto& fmap = sim->config().fingertips;
  tips << "time_s";
  for (const auto& f : fmap)
    for (const char* c : {"state", "target_x_m", "target_y_m", "target_z_m", "force_x_N", "force_y_N", "force_z_N"})
      tips << "," << f.name << "_" << c;
  tips << "\n";
  frames << "time_s,arrival_s,sequence,frame,parse_errors,valid\n";

  const int tracked = sim->scene().tracked_body;
  const Vec3 start = tracked >= 0 ? w.bodies[tracked].pose.t : Vec3::Zero();
  double max_rise = 0.0, max_coupling = 0.0, max_penetration = 0.0;
  double lifted_time = 0.0;  // simulated seconds with the box 2 cm or more above its start
  size_t next = 0;
  tracking::TargetSample sample;
  tracking::RecordedDatagram d;
  bool pending = reader.Next(&d);
  // frames depend on the simulated state only (no wall times in the HUD): two
  // replays of a log render identical frames
  FrameRecorder recorder;
  RenderOptions ro = opt.render;
  view::LiveView live_view;  // reads the recorder's snapshots on the render thread
  if (!opt.view.empty() && !live_view.Start(opt.view, sim->scene(), &error)) {
    std::fprintf(stderr, "replay: %s\n", error.c_str());
    return kExitUsage;
  }
  if (!opt.view.empty()) ro.reader = &live_view;
  // the view alone shows the step's wall time; written frames leave it out
  if (!recorder.Start(ro, sim->scene(), &error, ERecordMode::Headless, !opt.render.draws())) {
    std::fprintf(stderr, "replay: %s\n", error.c_str());
    return kExitUsage;
  }
  char tracker_text[160] = "";
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  int64_t step = 0;
  Progress progress("replay", steps, opt.quiet || opt.json);
  std::vector<double> step_ms;  // wall time per step: printed, never written (outputs stay deterministic)
  step_ms.reserve(static_cast<size_t>(steps));
  int max_iterations = 0, max_contacts = 0;
  double slowest_detect = 0, slowest_solve = 0;
  for (; step < steps && !StopRequested(); ++step) {
    // every datagram that arrived by now applies from this step on
    while (pending && arrival(d) <= w.time + 1e-12) {
      sim->Ingest(d.data.data(), d.data.size(), false, &sample);
      sample.sequence = static_cast<uint64_t>(d.sequence);
      sim->Push(sample);
      int mask = 0;
      for (int i = 0; i < sample.count; ++i) mask |= sample.valid[i] ? 1 << i : 0;
      frames << w.time;
      Row(frames, arrival(d));
      frames << "," << d.sequence << "," << sample.frame << "," << sample.parse_errors << "," << mask << "\n";
      ++next;
      pending = reader.Next(&d);
    }
    if (opt.realtime)
      std::this_thread::sleep_until(t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(w.time)));
    sim->Step();
    if (w.profile.rejected && w.rejected_steps <= 10)
      std::fprintf(stderr, "replay: step %lld (t = %.4f s) rejected, previous state kept: %s\n",
                   static_cast<long long>(w.step_count), w.time, RejectText(w).c_str());
    if (recorder.FrameDue(w)) sim->HudText(tracker_text, sizeof tracker_text);
    recorder.AfterStep(w, tracker_text);
    step_ms.push_back(1e3 * w.profile.total);
    if (1e3 * w.profile.total >= *std::max_element(step_ms.begin(), step_ms.end())) {
      slowest_detect = 1e3 * w.profile.detect;
      slowest_solve = 1e3 * w.profile.solve;
    }
    max_iterations = std::max(max_iterations, w.profile.iterations);
    max_contacts = std::max(max_contacts, w.profile.contacts);
    for (const ContactRow& r : w.rows) max_penetration = std::max(max_penetration, -r.contact.gap);
    if (tracked >= 0) {
      const double rise = w.bodies[tracked].pose.t.z() - start.z();
      max_rise = std::max(max_rise, rise);
      if (rise >= 0.02) lifted_time += dt;
    }
    for (int i = 0; i < sim->follower().size(); ++i) {
      const int b = sim->follower().body(i);
      if (b >= 0) max_coupling = std::max(max_coupling, CouplingSpringForce(w.bodies[b]).norm());
    }
    if ((step + 1) % 10 == 0) {
      WriteTrajectoryRow(traj, w);
      WriteContactsRows(contacts, w);
      tips << w.time;
      for (int i = 0; i < sim->follower().size(); ++i) {
        const int b = sim->follower().body(i);
        const Vec3 f = b >= 0 ? CouplingSpringForce(w.bodies[b]) : Vec3::Zero();
        const Vec3& t = sim->follower().target(i).t;
        tips << "," << tracking::TipStateName(sim->follower().state(i));
        for (double v : {t.x(), t.y(), t.z(), f.x(), f.y(), f.z()}) Row(tips, v);
      }
      tips << "\n";
    }
    if ((step + 1) % 100 == 0) {
      char detail[64];
      std::snprintf(detail, sizeof detail, "t=%.2f/%.2f s", w.time, duration);
      progress.Update(step + 1, detail);
    }
  }
  const bool interrupted = step < steps;
  progress.Done(interrupted ? "interrupted" : "");
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  // a video is finalised up to its last frame, also when stopped; the --out files are written either way
  const bool frames_ok = recorder.Finish(&error, opt.json);
  if (!opt.view.empty()) live_view.Stop(opt.json);
  if (!frames_ok) std::fprintf(stderr, "replay: %s\n", error.c_str());
  if (!reader.error().empty()) {
    std::fprintf(stderr, "replay: %s\n", reader.error().c_str());
    return kExitBadInput;
  }
  const tracking::ParseStats& ps = sim->parser().stats();
  const bool lifted = max_rise >= 0.02;
  if (!opt.json) {
    if (interrupted) std::printf("replay: interrupted at t=%.3f s\n", w.time);
    std::printf("replay: %lld steps in %.2f s wall (%.2fx real time); %zu datagrams applied; parse errors %s\n",
                static_cast<long long>(step), wall, wall > 0 ? w.time / wall : 0.0, next,
                FormatParseErrors(ps).c_str());
    std::printf("replay: %s\n", ReplayTallyText(*sim).c_str());
    if (tracked >= 0)
      std::printf("replay: %s highest rise %.2f mm, held 2 cm up for %.3f s, final (%.4f, %.4f, %.4f) m%s\n",
                  w.bodies[tracked].name.c_str(), 1e3 * max_rise, lifted_time, w.bodies[tracked].pose.t.x(),
                  w.bodies[tracked].pose.t.y(), w.bodies[tracked].pose.t.z(), lifted ? ": grasped and lifted" : "");
    if (!step_ms.empty()) {
      std::vector<double> sorted = step_ms;
      std::sort(sorted.begin(), sorted.end());
      std::printf("replay: step median %.3f ms, p99 %.3f ms, max %.3f ms (collision %.3f ms, solve %.3f ms); up to %d "
                  "contacts and %d Gauss-Seidel sweeps\n",
                  sorted[sorted.size() / 2], sorted[static_cast<size_t>(0.99 * (sorted.size() - 1))], sorted.back(),
                  slowest_detect, slowest_solve, max_contacts, max_iterations);
    }
    std::printf("replay: max coupling force %.2f N, max penetration %.3f mm, %lld rejected steps, %lld unconverged\n",
                max_coupling, 1e3 * max_penetration, static_cast<long long>(w.rejected_steps),
                static_cast<long long>(w.unconverged_steps));
    if (w.pass_throughs_let > 0)
      std::printf("replay: %lld steps let a body through another after %d rejected in a row; the last: %s\n",
                  static_cast<long long>(w.pass_throughs_let), w.params.pass_through_retries,
                  PassThroughText(w).c_str());
  }

  std::ostringstream js;
  js.precision(17);
  js << "{\"scene\":\"" << sim->scene().name << "\",\"log\":\"" << std::filesystem::path(log_path).filename().string()
     << "\",\"datagrams\":" << summary.datagrams << ",\"datagrams_applied\":" << next << ",\"steps\":" << step
     << ",\"interrupted\":" << (interrupted ? "true" : "false") << ",\"dt_s\":" << dt << ",\"simulated_s\":" << w.time << ",\"parse_errors\":" << ps.TotalErrors()
     << ",\"parse_errors_by_category\":" << ParseErrorsJson(ps) << ",\"rejected_steps\":" << w.rejected_steps
     << ",\"pass_throughs_let\":" << w.pass_throughs_let
     << ",\"unconverged_steps\":" << w.unconverged_steps << ",\"max_coupling_force_N\":" << max_coupling
     << ",\"max_penetration_m\":" << max_penetration << ",\"state_hash\":\"" << StateHashHex(w) << "\""
     << ",\"good_datagrams\":" << sim->tally().good << ",\"not_dtrack_datagrams\":" << sim->tally().not_dtrack
     << ",\"missing_datagrams\":" << sim->tally().missing << ",\"other_side_datagrams\":" << sim->tally().other_side;
  if (tracked >= 0)
    js << ",\"tracked_body\":\"" << w.bodies[tracked].name << "\",\"max_rise_m\":" << max_rise
       << ",\"lifted_s\":" << lifted_time << ",\"lifted\":" << (lifted ? "true" : "false") << ",\"final_position_m\":["
       << w.bodies[tracked].pose.t.x() << "," << w.bodies[tracked].pose.t.y() << "," << w.bodies[tracked].pose.t.z()
       << "]";
  js << "}";
  if (!opt.out.empty()) {
    if (!files.Close(opt.out, &error) || !WriteSummaryJson(opt.out, js.str(), &error)) {
      std::fprintf(stderr, "replay: %s\n", error.c_str());
      return kExitFailure;
    }
    if (!opt.json)
      std::printf("replay: wrote %s/trajectory.csv, contacts.csv, fingertips.csv, tracker.csv, summary.json\n", opt.out.c_str());
  }
  if (opt.json) std::printf("%s\n", js.str().c_str());
  if (interrupted) return kExitInterrupted;
  // a session that never drove the scene is no replay of it (the outputs are written all the
  // same); judged on the whole session only (a --duration may stop before its good datagrams)
  const std::string undriven = NothingDrivenText(sim->tally(), sim->config());
  if (!undriven.empty() && next == summary.datagrams) {
    std::fprintf(stderr, "replay: %s: %s\n", log_path.c_str(), undriven.c_str());
    return kExitBadInput;
  }
  return frames_ok ? kExitOk : kExitFailure;
}

}  // namespace

void AddReplayCommand(CLI::App& app, int* exit_code) {
  auto opt = std::make_shared<ReplayOptions>();
  CLI::App* cmd = app.add_subcommand(
      "replay", "Replay a recorded tracker session headless and deterministically (default scene "
                "config/tracked_hand.yaml)");
  cmd->add_option("args", opt->args,
                  "the session log, after the scene to replay it in (default config/tracked_hand.yaml)")
      ->type_name("[SCENE.yaml] FILE.lcmlog")
      ->required()
      ->expected(1, 2);
  cmd->add_option("--out", opt->out, "write trajectory.csv, contacts.csv (per body pair, e.g. each hand segment on the object), fingertips.csv, tracker.csv and summary.json into DIR")
      ->type_name("DIR");
  cmd->add_flag("--realtime", opt->realtime, "at the recorded pace instead of as fast as possible");
  cmd->add_option("--duration", opt->duration, "simulated seconds (default: the session plus --tail)")
      ->type_name("SECONDS")
      ->check(Positive("number of seconds"));
  cmd->add_option("--tail", opt->tail, "simulated seconds after the last datagram (default 0.5)")
      ->type_name("SECONDS")
      ->check(InRange(0.0, 1e6, "a number of seconds"));
  cmd->add_flag("--quiet", opt->quiet, "no progress bar or progress lines");
  AddThreadsOption(cmd, &opt->threads);
  cmd->add_flag("--json", opt->json, "print only the replay's summary as one JSON object (the summary.json of --out)");
  AddRenderOptions(cmd, &opt->render);
  cmd->add_option("--view", opt->view, "serve the live view (a page drawing the grasp in a browser) on this port, "
                  "on every interface unless an address is given; with --realtime (docs/render.md)")
      ->type_name("[ADDR:]PORT");
  SetHelpFooter(cmd,
                {{"graspsim replay assets/demo_session.lcmlog --out out/",
                  "the demo session in config/tracked_hand.yaml; the same files on every run"},
                 {"graspsim replay config/tracked_hand.yaml assets/demo_session.lcmlog --video replay.mp4",
                  "the same with an H.264 video"},
                 {"graspsim replay assets/demo_session.lcmlog --realtime --view 8080",
                  "at the recorded pace, with the live view at http://THIS-HOST:8080/"}},
                {{kExitOk, "the session was replayed to its end"},
                 {kExitFailure, "an output file or the video could not be written"},
                 {kExitUsage, "bad command line, or a render option that cannot be met (odd --size for --video, no "
                              "ffmpeg)"},
                 {kExitBadInput, "the scene or the session log was refused (or the log holds no datagrams, or none of them "
                                "drove the scene: the outputs are written, and the message says what they lacked)"},
                 {kExitInterrupted, "interrupted (Ctrl-C or SIGTERM): the outputs up to then are written"}});
  cmd->callback([opt, exit_code]() { *exit_code = Replay(*opt); });
}

}  // namespace gs::app
