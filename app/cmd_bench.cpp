// `graspsim bench NAME [--json] [--quick]`: benchmarks that print figures.
#include <memory>

#include "bench/bench.h"
#include "app/commands.h"
#include "bench/tradeoff.h"

namespace gs::app {

void AddBenchCommand(CLI::App& app, int* exit_code) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks: print figures (medians), --json for one object per line");
  bench->require_subcommand(1);
  auto opt = std::make_shared<BenchOptions>();
  auto add = [&](const char* name, const char* help, int (*fn)(const BenchOptions&)) {
    CLI::App* sub = bench->add_subcommand(name, help);
    sub->add_flag("--json", opt->json, "one JSON object per line; the last holds the headline figures");
    sub->add_flag("--quick", opt->quick, "fewer repetitions");
    sub->callback([opt, exit_code, fn]() { *exit_code = fn(*opt); });
    return sub;
  };
  add("collision", "the paper's Figure 6: collision detection at three grasp depths", RunBenchCollision);
  add("step", "the whole time step on the paper grasp at its deepest (target 1 ms median)", RunBenchStep);
  add("mls", "MLS projection accuracy and cost on a sphere and an ellipsoid at the paper's density", RunBenchMls);
  add("tracking", "DTrack parse throughput, 10 kHz receiving, latency from datagram arrival to fingertip force",
      RunBenchTracking);
  add("solver", "our NSGS against Siconos NSGS and PROX: time to reach error 1e-6 on the same problems",
      RunBenchSolver);
  add("soak", "a million steps of a looped tracker session holding the box: memory growth, drift, NaN (--quick: 50,000)",
      RunBenchSoak);
  add("render", "ms per frame for the paper grasp at 640x480 and 1280x720 (target 33 ms at 640x480)", RunBenchRender);
  add("scaling", "step time against contacts (50 to 2,000) and points per object (10,000 to 500,000), fitted slopes",
      RunBenchScaling);
  add("skip", "per feature (friction, deformation, nearby pairs, ...), the step time with it against the same scene "
      "without it, side by side",
      RunBenchSkip);
  CLI::App* realtime = add("realtime",
                           "issue 6's target: a 60 s tracked grasp session replayed at the recorded pace, 1 kHz "
                           "deadlines with 640x480 rendering at 30 fps and without: missed deadlines, step median",
                           RunBenchRealtime);
  realtime->add_option("--seconds", opt->seconds, "session length (default 60; --quick: 2)")->check(CLI::Range(0.1, 3600.0));
  realtime->add_option("--rt-priority", opt->rt_priority,
                       "SCHED_FIFO priority of the simulation loop, 0 for normal scheduling (refused without "
                       "CAP_SYS_NICE: said, and the run goes on)")
      ->check(CLI::Range(0, 99));
  realtime->add_option("--spin-us", opt->spin_us, "busy-wait this long before each deadline instead of sleeping")
      ->check(CLI::Range(0.0, 1000.0));
  realtime->add_flag("--skip-late-solves", opt->skip_late_solves,
                     "a step whose stages before the solve left no time for a sweep keeps the last forces instead of "
                     "sweeping late (never two steps in a row, never with over 5 % new contacts)");
  realtime->add_option("--step-budget", opt->step_budget,
                       "each step has this fraction of the timestep and ends at most as far into its slot: the "
                       "solver stops sweeping early, counted as a budget stop (0: no limit; default 0.8, as live)")
      ->check(CLI::Range(0.0, 10.0));
  realtime->add_option("--lead-steps", opt->lead_steps,
                       "a step may begin this many timesteps before its own slot, so that a long step uses what the "
                       "steps before it left over (deadlines unchanged: step k ends by (k+1) dt; default 1, as live; "
                       "0: each step has its slot only)")
      ->check(CLI::Range(0, 10));
  realtime
      ->add_option("--cpu", opt->cpu,
                   "the simulation loop's core; rendering runs on the others (-1: no pinning; without --cpu, the "
                   "lowest core no other graspsim loop runs on, from 0)")
      ->check(CLI::Range(-1, 1023))
      ->each([opt](const std::string&) { opt->cpu_given = true; });
  realtime->add_option("--steps-csv", opt->steps_csv,
                       "write one line per step of both runs (rendering or not, loop time, lateness, stage times, contacts, "
                       "sweeps, cache rebuilds) to this CSV file, to see what made a step late");
  realtime->add_option("--scene", opt->scene, "a scene with a tracker section (default config/tracked_paper_grasp.yaml, the paper's densities)");
  CLI::App* tradeoff = add("tradeoff",
                            "run time against error for every knob (points, control points, bandwidth, GS tolerance "
                            "and cap, dt), Pareto fronts",
                            RunBenchTradeoff);
  tradeoff->add_option("--plot", opt->plot_dir, "write DIR/tradeoff.csv and one PNG per series (needs gnuplot)")
      ->type_name("DIR");
  tradeoff->add_option("--knob", opt->knob, "sweep only this knob")
      ->check(CLI::IsMember(TradeoffKnobs()));
}

}  // namespace gs::app
