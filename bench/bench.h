// Benchmarks behind `graspsim bench NAME`. Each prints a human table, or with
// json one JSON object per line (the last one holds the headline figures).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "core/sampling.h"

namespace gs::app {

struct BenchOptions {
  bool json = false;
  bool quick = false;  ///< fewer repetitions (used by the tests)
  std::string plot_dir;  ///< bench tradeoff: write CSV and PNG plots here when set
  std::string knob;      ///< bench tradeoff: sweep only this knob when set
  std::vector<std::string> only;  ///< bench solver: only the problems whose name contains one of these
  double seconds = 0.0;  ///< bench realtime: session length (0: 60 s, --quick 2 s); bench step: the window's (0: the hold's)
  double from_s = -1.0;  ///< bench step: the timed window's start in simulated seconds (negative: the hold's start)
  std::string scene;     ///< bench realtime, step: the scene (empty: their default)
  bool pinch = false;    ///< bench step, realtime: a tracked hand's synthetic input is the precision pinch
  int rt_priority = 50;  ///< bench realtime: SCHED_FIFO priority of the loop (0: normal scheduling)
  double spin_us = 0.0;  ///< bench realtime: busy-wait before each deadline
  int cpu = 0;           ///< bench realtime: the simulation's core, the render thread on the others (-1: no pinning)
  bool cpu_given = false;  ///< bench realtime: --cpu given (else a core no other graspsim loop runs on)
  bool skip_late_solves = false;  ///< bench realtime: WorldParams::budget_may_skip_solve
  bool detect_every_step = false;  ///< bench realtime: no carried contacts (WorldParams::carry_contacts_after_s 0)
  int lead_steps = 1;  ///< bench realtime: a step may begin this many timesteps before its slot (StepSchedule)
  double step_budget = 0.8;  ///< bench realtime: a step ends this fraction of the timestep into its slot, the solver stopping early (0: no limit)
  std::string view;          ///< bench realtime: serve the live view during the rendering run on [ADDR:]PORT
  std::string steps_csv;     ///< bench realtime: write every step's stage times of the rendering run here when set
  int threads = 0;           ///< bench step, realtime: --threads (0: WorkerPool::ThreadsFor's default)
};

int RunBenchCollision(const BenchOptions& opt);
int RunBenchMls(const BenchOptions& opt);
int RunBenchStep(const BenchOptions& opt);
int RunBenchTracking(const BenchOptions& opt);
int RunBenchSolver(const BenchOptions& opt);
int RunBenchSoak(const BenchOptions& opt);
int RunBenchRender(const BenchOptions& opt);
int RunBenchScaling(const BenchOptions& opt);
int RunBenchTradeoff(const BenchOptions& opt);
int RunBenchSkip(const BenchOptions& opt);
int RunBenchRealtime(const BenchOptions& opt);

/// Accuracy of MLS projections of points near a sampled shape (errors in spacings).
struct MlsAccuracy {
  double spacing = 0.0;
  double max_err = NAN, median_err = NAN, max_deg = NAN, median_deg = NAN;
  double ns_per_projection = 0.0;
  int failed = 0;
};
MlsAccuracy MeasureMlsAccuracy(const ShapeDesc& shape, int points, double bandwidth_factor, bool quadric, int queries,
                               uint64_t seed);

}  // namespace gs::app
