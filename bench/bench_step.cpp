// `graspsim bench step [--scene FILE] [--json] [--quick]`: the whole time step on
// the paper's grasp at its deepest (the box lifted and held, all three fingertips
// pressed in): the scene is played up to the hold phase, then every step of the
// hold window is timed stage by stage. Medians; the step's collision detection on
// `--threads` threads (default 2 on 2 cores or more: WorkerPool::ThreadsFor; its
// figure is wall time, its traverse and interpenetration parts the threads' sums);
// the 1 kHz haptic rate needs the whole step
// under 1 ms. `--scene` times another scene: a scripted one
// from 1 s on; a tracked one driven by the synthetic hand (tracking/synthetic_hand.h;
// its whole-hand grasp when the scene has a tracked hand) in its hold.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

#include "bench/bench.h"
#include "scene/paths.h"
#include "scene/scene_file.h"
#include "scene/exit_code.h"
#include "session/console.h"
#include "session/tracked_sim.h"
#include "tracking/synthetic_hand.h"

namespace gs::app {
namespace {

// the value at fraction q of the sorted values (0.5: the median)
double QuantileOf(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))];
}
double MedianOf(const std::vector<double>& v) { return QuantileOf(v, 0.5); }
double MeanOf(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

// steps a scripted scene by its script, a tracked one by the synthetic hand's
// datagrams at 100 Hz in simulated time
class Driver {
 public:
  bool Load(const std::string& path, bool pinch, int threads, std::string* error) {
    auto built = std::make_unique<BuiltScene>();
    if (!LoadAndBuildScene(path, built.get(), error)) return false;
    if (!built->has_tracker) {
      built_ = std::move(built);
      if (threads > 1) {
        pool_ = std::make_unique<WorkerPool>(threads);
        built_->world.UseRunner(pool_.get());
      }
      return true;
    }
    drive_ = std::make_unique<SyntheticDrive>();
    if (!drive_->Load(path, error)) return false;
    drive_->sim().UseThreads(threads);
    drive_->hand().pinch = pinch && drive_->hand().whole_hand;
    return true;
  }
  World& world() { return drive_ ? drive_->world() : built_->world; }
  const std::string& name() { return drive_ ? drive_->sim().scene().name : built_->name; }
  /// the hold: a second from 1 s (scripted), or in the synthetic hand's hold
  double HoldStart() { return !drive_ ? 1.0 : (drive_->hand().whole_hand ? 2.1 : 1.95); }
  double HoldLength(bool quick) {
    return !drive_ || drive_->hand().whole_hand ? (quick ? 0.2 : 1.0) : (quick ? 0.2 : 0.3);
  }
  void Step() {
    if (drive_) {
      drive_->Step();
      return;
    }
    World& w = built_->world;
    built_->script.Apply(w, w.time + w.params.dt);
    w.Step();
  }

 private:
  std::unique_ptr<WorkerPool> pool_;  // before the worlds: they go first
  std::unique_ptr<BuiltScene> built_;
  std::unique_ptr<SyntheticDrive> drive_;
};

}  // namespace

int RunBenchStep(const BenchOptions& opt) {
  const std::string path = ResolveResource(opt.scene.empty() ? "config/paper_box_grasp.yaml" : opt.scene);
  auto driver = std::make_unique<Driver>();
  std::string error;
  const int threads = WorkerPool::ThreadsFor(opt.threads);
  if (!driver->Load(path, opt.pinch, threads, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 3;
  }
  World& w = driver->world();
  // the paper grasp's lift ends at 0.9 s; the grasp is deepest once it has settled in the hold
  const double start = opt.from_s >= 0.0 ? opt.from_s : driver->HoldStart();
  const double window = opt.seconds > 0.0 ? opt.seconds : driver->HoldLength(opt.quick);
  while (w.time < start - 0.5 * w.params.dt) driver->Step();
  std::vector<double> total, collision, space, space_rigid, space_deform, solve, motion, free_motion, iters;
  std::vector<double> contacts, projections, fits, node_pairs, leaf_pairs, traverse, interp, refit;
  std::vector<double> sides, sides_reused, weights_reused, cache_hits, cache_builds, on_lanes, clear;
  double residual_max = 0.0;
  int unconverged = 0, rejected = 0;
  const int steps = std::max(1, static_cast<int>(std::llround(window / w.params.dt)));
  for (int i = 0; i < steps && !StopRequested(); ++i) {
    driver->Step();
    const StepProfile& p = w.profile;
    total.push_back(1e3 * p.total);
    free_motion.push_back(1e3 * p.free_motion);
    collision.push_back(1e3 * p.detect);
    space.push_back(1e3 * (p.fill_w_rigid + p.fill_w_deform));
    space_rigid.push_back(1e3 * p.fill_w_rigid);
    space_deform.push_back(1e3 * p.fill_w_deform);
    solve.push_back(1e3 * p.solve);
    motion.push_back(1e3 * p.constrained_motion);
    iters.push_back(p.iterations);
    contacts.push_back(p.contacts);
    projections.push_back(p.collision.projections);
    fits.push_back(p.collision.fits);
    node_pairs.push_back(p.collision.node_pairs);
    leaf_pairs.push_back(p.collision.leaf_pairs);
    traverse.push_back(1e3 * p.traverse);
    interp.push_back(1e3 * p.interpenetration);
    refit.push_back(1e3 * p.refit);
    sides.push_back(p.work.w_deform_sides);
    sides_reused.push_back(p.work.w_deform_reused);
    weights_reused.push_back(p.work.weights_reused);
    cache_hits.push_back(p.collision.cache_hits);
    cache_builds.push_back(p.collision.cache_builds);
    on_lanes.push_back(p.work.pairs_on_lanes);
    clear.push_back(p.work.pairs_clear);
    residual_max = std::max(residual_max, p.residual);
    unconverged += p.converged ? 0 : 1;
    rejected += p.rejected ? 1 : 0;
  }
  if (StopRequested()) {  // Ctrl-C: a window cut short is no measurement
    std::fprintf(stderr, "graspsim bench step: interrupted after %zu of %d steps; nothing reported\n", total.size(), steps);
    return kExitInterrupted;
  }
  const double step_ms = MedianOf(total);
  if (opt.json) {
    for (int i = 0; i < steps; i += std::max(1, steps / 20))
      std::printf("{\"step\":%d,\"contacts\":%d,\"iterations\":%d,\"step_ms\":%.4f}\n", i,
                  static_cast<int>(contacts[i]), static_cast<int>(iters[i]), total[i]);
    std::printf(
        "{\"bench\":\"step\",\"scene\":\"%s\",\"threads\":%d,\"pairs_on_lanes_median\":%d,\"pairs_clear_mean\":%.2f,\"steps\":%d,\"contacts\":%d,\"free_motion_ms_median\":%.4f,"
        "\"collision_ms_median\":%.4f,\"refit_ms_median\":%.4f,\"traverse_ms_median\":%.4f,\"interpenetration_ms_median\":%.4f,"
        "\"sphere_tests_median\":%d,\"leaf_pairs_median\":%d,\"projections_median\":%d,\"mls_fits_median\":%d,"
        "\"contact_space_ms_median\":%.4f,\"solve_ms_median\":%.4f,"
        "\"contact_space_rigid_ms_median\":%.4f,\"contact_space_deform_ms_median\":%.4f,"
        "\"pair_cache_hits_median\":%d,\"pair_cache_builds_median\":%d,\"w_deform_sides_median\":%d,\"w_deform_reused_median\":%d,\"weights_reused_median\":%d,"
        "\"constrained_motion_ms_median\":%.4f,\"gs_iterations_median\":%d,\"gs_iterations_max\":%d,"
        "\"residual_max\":%.3g,\"unconverged_steps\":%d,\"rejected_steps\":%d,\"target_ms\":1.0,"
        "\"from_s\":%.3f,\"seconds\":%.3f,\"step_ms_p90\":%.4f,\"step_ms_max\":%.4f,\"step_ms_median\":%.4f}\n",
        driver->name().c_str(), threads, static_cast<int>(MedianOf(on_lanes)), MeanOf(clear), steps, static_cast<int>(MedianOf(contacts)), MedianOf(free_motion), MedianOf(collision),
        MedianOf(refit), MedianOf(traverse), MedianOf(interp), static_cast<int>(MedianOf(node_pairs)),
        static_cast<int>(MedianOf(leaf_pairs)), static_cast<int>(MedianOf(projections)),
        static_cast<int>(MedianOf(fits)), MedianOf(space), MedianOf(solve), MedianOf(space_rigid),
        MedianOf(space_deform), static_cast<int>(MedianOf(cache_hits)), static_cast<int>(MedianOf(cache_builds)),
        static_cast<int>(MedianOf(sides)), static_cast<int>(MedianOf(sides_reused)),
        static_cast<int>(MedianOf(weights_reused)), MedianOf(motion), static_cast<int>(MedianOf(iters)),
        static_cast<int>(*std::max_element(iters.begin(), iters.end())), residual_max, unconverged, rejected,
        start, window, QuantileOf(total, 0.9), QuantileOf(total, 1.0), step_ms);
  } else {
    std::printf("graspsim bench step: %s, %s t = %.3g..%.3g s, %d steps of %.3g ms\n", driver->name().c_str(),
                opt.from_s >= 0.0 ? "window" : "hold phase", start, start + window, steps, 1e3 * w.params.dt);
    std::printf("  threads %d (body pairs on the workers' lanes: %d, median)\n", threads,
                static_cast<int>(MedianOf(on_lanes)));
    std::printf("  contacts (median)              %8d\n", static_cast<int>(MedianOf(contacts)));
    std::printf("  free motion (ms, median)       %8.4f\n", MedianOf(free_motion));
    std::printf("  collision detection (ms)       %8.4f\n", MedianOf(collision));
    std::printf("    refit of the deformed trees  %8.4f\n", MedianOf(refit));
    std::printf("    traverse / interpenetration  %8.4f / %.4f%s\n", MedianOf(traverse), MedianOf(interp),
                MedianOf(on_lanes) > 0 ? "   (summed over the threads)" : "");
    std::printf("    sphere tests %d, leaf pairs %d, projections %d, MLS fits %d (medians)\n",
                static_cast<int>(MedianOf(node_pairs)), static_cast<int>(MedianOf(leaf_pairs)),
                static_cast<int>(MedianOf(projections)), static_cast<int>(MedianOf(fits)));
    std::printf("    body pairs proven apart, not detected: %.2f a step (mean)\n", MeanOf(clear));
    std::printf("    body pairs served by their leaf-pair cache %d, rebuilt %d (medians)\n",
                static_cast<int>(MedianOf(cache_hits)), static_cast<int>(MedianOf(cache_builds)));
    std::printf("  contact space (ms)             %8.4f\n", MedianOf(space));
    std::printf("    rigid part: frames, J, W_rigid %8.4f   (every block rebuilt)\n", MedianOf(space_rigid));
    std::printf("    deformable part: W_deform      %8.4f   (%d of %d sides reused, %d interpolations kept, median)\n",
                MedianOf(space_deform), static_cast<int>(MedianOf(sides_reused)), static_cast<int>(MedianOf(sides)),
                static_cast<int>(MedianOf(weights_reused)));
    std::printf("  solve (ms)                     %8.4f\n", MedianOf(solve));
    std::printf("  constrained motion (ms)        %8.4f\n", MedianOf(motion));
    std::printf("  Gauss-Seidel sweeps  median %d, max %d\n", static_cast<int>(MedianOf(iters)),
                static_cast<int>(*std::max_element(iters.begin(), iters.end())));
    std::printf("  residual max %.3g, %d steps at the sweep cap, %d rejected\n", residual_max, unconverged,
                rejected);
    std::printf("  whole step (ms, median)        %8.4f   (target 1 ms; the paper: 53 ms)\n", step_ms);
    std::printf("    p90 / max                    %8.4f / %.4f\n", QuantileOf(total, 0.9), QuantileOf(total, 1.0));
  }
  return 0;
}

}  // namespace gs::app
