// `graspsim run [SCENE] [--out DIR]`: runs a scene headless at full speed, prints
// the paper's timing tables and writes timings, contacts and a summary.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include "app/cli_help.h"
#include "app/commands.h"
#include "fclib/fclib_io.h"
#include "scene/paths.h"
#include "session/console.h"
#include "session/frame_recorder.h"
#include "session/run_report.h"
#include "session/worker_pool.h"
#include "scene/scene_file.h"

namespace gs::app {
namespace {

struct RunOptions {
  std::string scene = "config/paper_box_grasp.yaml";
  std::string out;
  int every = 1;  ///< trajectory.csv and contacts.csv every Nth step
  double duration = -1.0;
  bool quiet = false;
  bool json = false;  ///< stdout: summary.json's object as one line, nothing else
  std::string export_fclib;  ///< folder for every step's contact problem (FCLIB)
  int export_every = 1;
  RenderOptions render;  ///< --frames, --video, --size, --fps (docs/render.md)
  int threads = 0;       ///< --threads (0: WorkerPool::ThreadsFor's default)
};

// writes the last step's contact problem as DIR/step_NNNNNN.hdf5 (with its solution)
bool ExportStep(const std::string& dir, const std::string& scene, World& w, int* exported, std::string* error) {
  if (w.rows.empty()) return true;
  FcProblem p;
  Eigen::VectorXd r;
  AssembleContactProblem(w, &p, &r);
  char name[64];
  std::snprintf(name, sizeof name, "step_%06lld.hdf5", static_cast<long long>(w.step_count));
  char desc[160];
  std::snprintf(desc, sizeof desc, "step %lld at t = %.4f s, %d contacts; solution: the step's forces (error %.3g)",
                static_cast<long long>(w.step_count), w.time, p.contacts, w.profile.residual);
  if (!WriteFclibLocal(dir + "/" + name, p, "graspsim " + scene, desc, &r, error)) return false;
  ++*exported;
  return true;
}

// Every output is checked (and its folders made) before the scene is built: a
// mistake in an option costs no simulation.
bool CheckOutputs(const RunOptions& opt, std::string* error) {
  // --out first: its folder may be where --video goes
  if (!opt.out.empty() && !CheckOutputFolder("--out", opt.out, error)) return false;
  if (!CheckRenderOptions(opt.render, error)) return false;
  if (opt.export_fclib.empty()) return true;
  if (!FclibAvailable()) {
    *error = "--export-fclib: graspsim was built without FCLIB (install libfclib-dev and rebuild)";
    return false;
  }
  return CheckOutputFolder("--export-fclib", opt.export_fclib, error);
}

std::string SummaryJson(const BuiltScene& built, const RunOptions& opt, int64_t steps_done, double simulated,
                        double wall, double residual_max, double max_rise, bool interrupted) {
  const World& w = built.world;
  const int tracked = built.tracked_body;
  std::ostringstream js;
  js << "{\"scene\":\"" << built.name << "\",\"steps\":" << steps_done << ",\"dt_s\":" << w.params.dt
     << ",\"simulated_s\":" << simulated << ",\"wall_s\":" << wall << ",\"interrupted\":"
     << (interrupted ? "true" : "false") << ",\"rejected_steps\":" << w.rejected_steps
     << ",\"pass_through_steps\":" << w.pass_through_steps << ",\"pass_throughs_let\":" << w.pass_throughs_let
     << ",\"every\":" << opt.every
     << ",\"unconverged_steps\":" << w.unconverged_steps << ",\"residual_max\":" << residual_max
     << ",\"state_hash\":\"" << StateHashHex(w) << "\"";
  if (tracked >= 0)
    js << ",\"tracked_body\":\"" << w.bodies[tracked].name << "\",\"max_rise_m\":" << max_rise
       << ",\"final_position_m\":[" << w.bodies[tracked].pose.t.x() << "," << w.bodies[tracked].pose.t.y() << ","
       << w.bodies[tracked].pose.t.z() << "]";
  js << "}";
  return js.str();
}

void LogRejected(const World& w) {
  if (w.profile.rejected && w.rejected_steps <= 10)
    std::fprintf(stderr, "graspsim run: step %lld (t = %.4f s) rejected, previous state kept: %s%s\n",
                 static_cast<long long>(w.step_count), w.time, RejectText(w).c_str(),
                 w.rejected_steps == 10 ? " (further rejected steps are counted, not logged)" : "");
}

std::string StepDetail(const World& w) {
  char text[160];
  std::snprintf(text, sizeof text, "t=%.3f s  contacts=%d  iterations=%d  residual=%.1e  step=%.3f ms", w.time,
                w.profile.contacts, w.profile.iterations, w.profile.residual, 1e3 * w.profile.total);
  return text;
}

int Run(const RunOptions& opt) {
  using Clock = std::chrono::steady_clock;
  std::string error;
  if (!CheckOutputs(opt, &error)) {
    std::fprintf(stderr, "graspsim run: %s\n", error.c_str());
    return kExitUsage;
  }
  const std::string path = ResolveResource(opt.scene);
  if (!opt.quiet && !opt.json) std::printf("building scene %s ...\n", path.c_str());
  const auto t0 = Clock::now();
  auto built = std::make_unique<BuiltScene>();
  if (!LoadAndBuildScene(path, built.get(), &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return kExitBadInput;
  }
  if (!built->sizes_note.empty()) std::fprintf(stderr, "%s\n", built->sizes_note.c_str());
  if (StopRequested()) return kExitInterrupted;
  World& w = built->world;
  const int threads = WorkerPool::ThreadsFor(opt.threads);
  std::unique_ptr<WorkerPool> pool = threads > 1 ? std::make_unique<WorkerPool>(threads) : nullptr;
  w.UseRunner(pool.get());
  const double build_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const double duration = opt.duration > 0 ? opt.duration : built->duration;
  const int64_t steps = static_cast<int64_t>(std::llround(duration / w.params.dt));
  size_t points = 0;
  for (const Body& b : w.bodies) points += b.geometry.cloud.size();
  if (!opt.json) {
    std::printf("scene %s: %zu bodies, %zu fingers, %zu surface points, built in %.2f s\n", built->name.c_str(),
                w.bodies.size(), w.hand.fingers.size(), points, build_s);
    std::printf("simulating %.3f s in %lld steps of %.3g ms\n", duration, static_cast<long long>(steps),
                1e3 * w.params.dt);
  }

  int exported = 0;
  std::vector<StepRecord> records;
  records.reserve(static_cast<size_t>(steps));
  const int tracked = built->tracked_body;
  const Vec3 start = tracked >= 0 ? w.bodies[tracked].pose.t : Vec3::Zero();
  double max_rise = 0.0, residual_max = 0.0;
  FrameRecorder frames;
  if (!frames.Start(opt.render, *built, &error)) {
    std::fprintf(stderr, "graspsim run: %s\n", error.c_str());
    return kExitUsage;
  }
  StepFiles files;
  if (!opt.out.empty() && !files.Open(opt.out, w, opt.every, &error)) {
    std::fprintf(stderr, "graspsim run: %s\n", error.c_str());
    return kExitFailure;
  }
  Progress progress("run", steps, opt.quiet || opt.json);
  const auto t1 = Clock::now();
  int64_t done = 0;
  for (; done < steps && !StopRequested(); ++done) {
    built->script.Apply(w, w.time + w.params.dt);
    w.Step();
    records.push_back(RecordStep(w));
    LogRejected(w);
    if (!opt.out.empty()) files.AfterStep(w);
    frames.AfterStep(w);
    if (!opt.export_fclib.empty() && w.step_count % opt.export_every == 0 &&
        !ExportStep(opt.export_fclib, built->name, w, &exported, &error)) {
      std::fprintf(stderr, "graspsim run: %s\n", error.c_str());
      return kExitFailure;
    }
    residual_max = std::max(residual_max, w.profile.residual);
    if (tracked >= 0) max_rise = std::max(max_rise, w.bodies[tracked].pose.t.z() - start.z());
    if ((done + 1) % 100 == 0) {
      progress.Update(done + 1, StepDetail(w));
      if (!opt.out.empty() && (done + 1) % 1000 == 0) files.Flush();
    }
  }
  const bool interrupted = done < steps;
  progress.Done(interrupted ? "interrupted" : "");
  const double wall = std::chrono::duration<double>(Clock::now() - t1).count();
  const double simulated = static_cast<double>(done) * w.params.dt;
  if (interrupted && !opt.json)
    std::printf("run: interrupted at t=%.3f s after %lld of %lld steps; writing what was computed\n", w.time,
                static_cast<long long>(done), static_cast<long long>(steps));
  const bool frames_ok = frames.Finish(&error, opt.json);  // a video is finalised up to its last frame, also when stopped
  if (!frames_ok) std::fprintf(stderr, "graspsim run: %s\n", error.c_str());
  if (!opt.json) {
    PrintPaperTables(records);
    if (!opt.export_fclib.empty())
      std::printf("exported %d contact problems (FCLIB) to %s\n", exported, opt.export_fclib.c_str());
    std::printf("\n%lld steps in %.2f s wall (%.2fx real time); %lld steps hit the iteration cap, %lld rejected\n",
                static_cast<long long>(done), wall, wall > 0 ? simulated / wall : 0.0,
                static_cast<long long>(w.unconverged_steps), static_cast<long long>(w.rejected_steps));
    if (tracked >= 0)
      std::printf("%s: highest rise %.2f mm, final position (%.4f, %.4f, %.4f) m\n", w.bodies[tracked].name.c_str(),
                  1e3 * max_rise, w.bodies[tracked].pose.t.x(), w.bodies[tracked].pose.t.y(),
                  w.bodies[tracked].pose.t.z());
  }
  const std::string js = SummaryJson(*built, opt, done, simulated, wall, residual_max, max_rise, interrupted);
  if (!opt.out.empty()) {
    if (!files.Close(&error) || !WriteSummaryJson(opt.out, js, &error)) {
      std::fprintf(stderr, "graspsim run: %s\n", error.c_str());
      return kExitFailure;
    }
    if (!opt.json) std::printf("wrote %s/trajectory.csv, contacts.csv, timings.csv, summary.json\n", opt.out.c_str());
  }
  if (opt.json) std::printf("%s\n", js.c_str());
  if (interrupted) return kExitInterrupted;
  if (!frames_ok) return kExitFailure;
  // a body that went through another is a failed run, even though its steps were undone
  if (w.pass_through_steps > 0 || w.pass_throughs_let > 0) {
    std::fprintf(stderr,
                 "graspsim run: %lld steps rejected because a body passed through another (%lld let through after %d "
                 "rejected in a row); the last: %s\n",
                 static_cast<long long>(w.pass_through_steps), static_cast<long long>(w.pass_throughs_let),
                 w.params.pass_through_retries, PassThroughText(w).c_str());
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace

void AddRunCommand(CLI::App& app, int* exit_code) {
  auto opt = std::make_shared<RunOptions>();
  CLI::App* run = app.add_subcommand("run", "Run a scene headless as fast as possible (default: the paper's box grasp)");
  run->add_option("scene", opt->scene, "the scene file to run (docs/scene-format.md)")
      ->type_name("SCENE.yaml")
      ->capture_default_str();
  run->add_option("--out", opt->out,
                  "write trajectory.csv, contacts.csv, timings.csv and summary.json into DIR (README: Output files)")
      ->type_name("DIR");
  run->add_option("--every", opt->every, "with --out: trajectory.csv and contacts.csv every Nth step (default 1)")
      ->type_name("N")
      ->check(PositiveInt("number of steps"));
  run->add_option("--duration", opt->duration, "simulated seconds to run (default: the scene's duration_s)")
      ->type_name("SECONDS")
      ->check(Positive("number of seconds"));
  run->add_option("--export-fclib", opt->export_fclib,
                  "write every step's contact problem (and its solution) as FCLIB files DIR/step_NNNNNN.hdf5")
      ->type_name("DIR");
  run->add_option("--export-every", opt->export_every, "with --export-fclib: every Nth step only (default 1)")
      ->type_name("N")
      ->check(PositiveInt("number of steps"));
  run->add_flag("--quiet", opt->quiet, "no progress lines");
  AddThreadsOption(run, &opt->threads);
  run->add_flag("--json", opt->json, "print only the run's summary as one JSON object (the summary.json of --out)");
  AddRenderOptions(run, &opt->render);
  SetHelpFooter(run,
                {{"graspsim run config/paper_box_grasp.yaml --out out/ --video grasp.mp4",
                  "the paper's box grasp (close, lift, hold, release): its timing tables beside the paper's, "
                  "the output files in out/ and an H.264 video"},
                 {"graspsim run config/tracked_hand.yaml --duration 0.5 --frames frames/ --fps 10",
                  "half a simulated second of the lighter scene, a PNG frame every 0.1 simulated seconds in frames/"}},
                {{kExitOk, "the run finished and no body passed through another"},
                 {kExitFailure, "a body passed through another (those steps were rejected), or an output file "
                                "could not be written"},
                 {kExitUsage, "bad command line: an unknown option, a value out of range, a render option that "
                              "cannot be met (odd --size for --video, no ffmpeg, no FCLIB for --export-fclib)"},
                 {kExitBadInput, "the scene (or a mesh it names) was refused: FILE:LINE:COLUMN and what to change"},
                 {kExitInterrupted, "interrupted (Ctrl-C, SIGTERM): what was computed up to the stop is written"}});
  run->callback([opt, exit_code]() { *exit_code = Run(*opt); });
}

}  // namespace gs::app
