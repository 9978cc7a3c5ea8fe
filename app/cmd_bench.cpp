// `graspsim bench NAME [--json] [--quick]`: benchmarks that print figures.
#include <memory>

#include "bench/bench.h"
#include "app/cli_help.h"
#include "app/commands.h"
#include "bench/tradeoff.h"

namespace gs::app {

void AddBenchCommand(CLI::App& app, int* exit_code) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks: print figures (medians), --json for one object per line");
  bench->require_subcommand(1);
  auto opt = std::make_shared<BenchOptions>();
  auto add = [&](const char* name, const char* help, int (*fn)(const BenchOptions&)) {
    CLI::App* sub = bench->add_subcommand(name, help);
    sub->group("Benchmarks");
    sub->add_flag("--json", opt->json, "one JSON object per line; the last holds the headline figures");
    sub->add_flag("--quick", opt->quick, "fewer repetitions (a quick look, not a measurement)");
    sub->callback([opt, exit_code, fn]() { *exit_code = fn(*opt); });
    return sub;
  };
  const std::pair<int, std::string> usage{kExitUsage, "bad command line"};
  const std::pair<int, std::string> interrupted{kExitInterrupted, "interrupted (Ctrl-C, SIGTERM): the figures measured up to the stop are printed"};
  SetHelpFooter(bench,
                {{"graspsim bench step --quick", "the whole time step on the paper grasp, a quick look"},
                 {"graspsim bench solver --json", "our solver against Siconos, one JSON object per problem"}},
                {{kExitOk, "the benchmark ran (its figures are printed)"},
                 {kExitFailure, "the benchmark ran and a check it makes failed (see each benchmark's --help)"},
                 {kExitUsage, "bad command line, or an unknown benchmark (the list is printed)"},
                 {kExitBadInput, "a scene or problem file the benchmark needs was refused"},
                 interrupted});
  SetHelpFooter(add("collision", "the paper's Figure 6: collision detection at three grasp depths", RunBenchCollision),
                {{"graspsim bench collision --quick", "Figure 6's collision times with fewer repetitions"},
                 {"graspsim bench collision --json", "the same figures as JSON lines"}},
                {{kExitOk, "the figures are printed"},
                 {kExitFailure, "the paper's box or fingertip geometry could not be built"},
                 usage, interrupted});
  CLI::App* step = add("step", "the whole time step on the paper grasp at its deepest (target 1 ms median)", RunBenchStep);
  step->add_option("--scene", opt->scene,
                   "another scene: a scripted one is timed from 1 s on; a tracked one is driven by the synthetic hand "
                   "(the whole-hand grasp when it has a tracked hand) and timed in its hold")
      ->type_name("SCENE.yaml");
  step->add_flag("--pinch", opt->pinch,
                 "a tracked hand's synthetic input is the precision pinch (config/tracked_whole_hand.yaml) instead of "
                 "the power grasp");
  step->add_option("--from", opt->from_s,
                   "time the steps from this simulated second instead of the hold's start (the closing of the "
                   "synthetic power grasp: 1.0)")
      ->type_name("SECONDS")
      ->check(InRange(0.0, 3600.0, "a simulated time in seconds"));
  step->add_option("--seconds", opt->seconds,
                   "the length of the timed window (default: the hold's, 1 s; --quick 0.2 s)")
      ->type_name("SECONDS")
      ->check(InRange(0.001, 3600.0, "a number of seconds"));
  AddThreadsOption(step, &opt->threads);
  SetHelpFooter(step,
                {{"graspsim bench step --quick", "step and stage medians on config/paper_box_grasp.yaml"},
                 {"graspsim bench step --scene config/whole_hand_power_grasp.yaml",
                  "the whole tracked hand holding the box (t = 2.1..3.1 s of the synthetic power grasp)"},
                 {"graspsim bench step --scene config/tracked_whole_hand.yaml --pinch",
                  "the same hand pinching the box between thumb and index"},
                 {"graspsim bench step --scene config/whole_hand_paper_density.yaml --from 1.0 --seconds 0.3",
                  "the fingers closing on the box instead of the hold"}},
                {{kExitOk, "the figures are printed (a median over 1 ms is reported, not an error)"},
                 usage, {kExitBadInput, "config/paper_box_grasp.yaml was refused"}, interrupted});
  SetHelpFooter(add("mls", "MLS projection accuracy and cost on a sphere and an ellipsoid at the paper's density",
                    RunBenchMls),
                {{"graspsim bench mls --quick", "projection error and microseconds per point"}},
                {{kExitOk, "the figures are printed"}, usage, interrupted});
  SetHelpFooter(add("tracking", "DTrack parse throughput, 10 kHz receiving, latency from datagram arrival to "
                                "fingertip force",
                    RunBenchTracking),
                {{"graspsim bench tracking --quick", "parse rate, a 10 kHz flood, and arrival-to-force latency"}},
                {{kExitOk, "the median latency from arrival to force is at most one step"},
                 {kExitFailure, "the median latency is over one step, or the receiving loop could not run"},
                 usage, interrupted});
  CLI::App* solver = add("solver", "our NSGS against Siconos NSGS and PROX: time to reach error 1e-6 on the same problems",
                         RunBenchSolver);
  solver->add_option("--only", opt->only, "run only the problems whose name contains one of these words")
      ->type_name("NAME[,NAME...]")
      ->delimiter(',');
  SetHelpFooter(solver,
                {{"graspsim bench solver --quick", "the FCLIB problems and generated families, without the paper grasp"},
                 {"graspsim bench solver --json", "every problem as a JSON line, the headline last"},
                 {"graspsim bench solver --only stack_10,gripped", "the problems named stack_10... and gripped..."}},
                {{kExitOk, "every problem was solved"},
                 {kExitFailure, "a problem was left unsolved"},
                 {kExitUsage, "bad command line; or CI is set in the environment and Siconos or FCLIB is not "
                              "built in"},
                 {kExitBadInput, "an FCLIB problem file could not be read, or the paper grasp had no contacts"},
                 interrupted});
  SetHelpFooter(add("soak", "a million steps of a looped tracker session holding the box: memory growth, drift, NaN "
                            "(--quick: 50,000)",
                    RunBenchSoak),
                {{"graspsim bench soak --quick", "50,000 steps instead of a million"}},
                {{kExitOk, "memory stayed flat, the box is still held and no state became NaN"},
                 {kExitFailure, "memory grew by 1 MB or more, the box was dropped, or a NaN appeared"},
                 usage, {kExitBadInput, "the soak's scene or session could not be loaded"}, interrupted});
  SetHelpFooter(add("render", "ms per frame for the paper grasp at 640x480 and 1280x720 (target 33 ms at 640x480)",
                    RunBenchRender),
                {{"graspsim bench render --quick", "frame times with fewer frames"}},
                {{kExitOk, "the figures are printed (a frame over 33 ms is reported, not an error)"},
                 {kExitFailure, "the off-screen renderer could not start or a PNG could not be written"},
                 usage, {kExitBadInput, "config/paper_box_grasp.yaml was refused"}, interrupted});
  SetHelpFooter(add("scaling", "step time against contacts (50 to 2,000) and points per object (10,000 to 500,000), "
                               "fitted slopes",
                    RunBenchScaling),
                {{"graspsim bench scaling --quick", "fewer sizes and repetitions"}},
                {{kExitOk, "the figures are printed"}, usage, interrupted});
  SetHelpFooter(add("skip", "per feature (friction, deformation, nearby pairs, ...), the step time with it against the "
                            "same scene without it, side by side",
                    RunBenchSkip),
                {{"graspsim bench skip --quick", "each feature's cost with fewer repetitions"}},
                {{kExitOk, "the figures are printed"}, usage, interrupted});
  CLI::App* realtime = add("realtime",
                           "the real-time target: a 60 s tracked grasp session replayed at the recorded pace, 1 kHz "
                           "deadlines with 640x480 rendering at 30 fps and without: missed deadlines (target none), "
                           "step median (target 1 ms)",
                           RunBenchRealtime);
  AddThreadsOption(realtime, &opt->threads);
  realtime->add_option("--seconds", opt->seconds, "session length in seconds (default 60; --quick: 2)")
      ->type_name("SECONDS")
      ->check(InRange(0.1, 3600.0, "a number of seconds"));
  realtime->add_option("--rt-priority", opt->rt_priority,
                       "SCHED_FIFO priority of the simulation loop, 0 for normal scheduling (refused without "
                       "CAP_SYS_NICE: said, and the run goes on)")
      ->type_name("N")
      ->check(IntInRange(0, 99, "a SCHED_FIFO priority"));
  realtime->add_option("--spin-us", opt->spin_us,
                       "busy-wait this many microseconds before each deadline instead of sleeping")
      ->type_name("MICROSECONDS")
      ->check(InRange(0.0, 1000.0, "a number of microseconds"));
  realtime->add_flag("--detect-every-step", opt->detect_every_step,
                     "detect collisions in every step; without it, a step that follows one past its step budget "
                     "carries that step's contacts, moved with the bodies (never two steps in a row), as live does");
  realtime->add_flag("--skip-late-solves", opt->skip_late_solves,
                     "a step whose stages before the solve left no time for a sweep keeps the last forces instead of "
                     "sweeping late (never two steps in a row, never with over 5 % new contacts)");
  realtime->add_option("--step-budget", opt->step_budget,
                       "each step has this fraction of the timestep and ends at most as far into its slot: the "
                       "solver stops sweeping early, counted as a budget stop (0: no limit; default 0.8, as live)")
      ->type_name("FRACTION")
      ->check(InRange(0.0, 10.0, "a fraction of the timestep"));
  realtime->add_option("--lead-steps", opt->lead_steps,
                       "a step may begin this many timesteps before its own slot, so that a long step uses what the "
                       "steps before it left over (deadlines unchanged: step k ends by (k+1) dt; default 1, as live; "
                       "0: each step has its slot only)")
      ->type_name("N")
      ->check(IntInRange(0, 10, "a whole number of timesteps"));
  realtime
      ->add_option("--cpu", opt->cpu,
                   "the simulation loop's core; rendering runs on the others (-1: no pinning; without --cpu, the "
                   "lowest core no other graspsim loop runs on, from 0)")
      ->type_name("CORE")
      ->check(IntInRange(-1, 1023, "a core number"))
      ->each([opt](const std::string&) { opt->cpu_given = true; });
  realtime->add_option("--view", opt->view,
                       "serve the live view during the run with rendering (as live --view), to measure the loop with "
                       "a browser connected; view_requests in the JSON says how many requests it served")
      ->type_name("[ADDR:]PORT");
  realtime->add_option("--steps-csv", opt->steps_csv,
                       "write one line per step of both runs (rendering or not, loop time, lateness, stage times, contacts, "
                       "sweeps, cache rebuilds) to this CSV file, to see what made a step late")
      ->type_name("FILE.csv");
  realtime->add_option("--scene", opt->scene, "a scene with a tracker section (default config/tracked_paper_grasp.yaml, the paper's densities)")
      ->type_name("SCENE.yaml");
  realtime->add_flag("--pinch", opt->pinch,
                     "a tracked hand's synthetic input is the precision pinch (config/tracked_whole_hand.yaml) instead "
                     "of the power grasp");
  SetHelpFooter(realtime,
                {{"graspsim bench realtime --quick", "a 2 s session instead of 60 s"},
                 {"graspsim bench realtime --seconds 10 --scene config/tracked_hand.yaml --steps-csv steps.csv",
                  "10 s on the lighter scene, one CSV line per step to see what made a step late"}},
                {{kExitOk, "both runs finished (missed deadlines are reported in the figures, not an error)"},
                 {kExitUsage, "bad command line"},
                 {kExitBadInput, "the scene was refused, a run could not be set up, or the --steps-csv file cannot "
                                 "be written"},
                 interrupted});
  CLI::App* tradeoff = add("tradeoff",
                            "run time against error for every knob (points, control points, bandwidth, GS tolerance "
                            "and cap, dt), Pareto fronts",
                            RunBenchTradeoff);
  tradeoff->add_option("--plot", opt->plot_dir, "write DIR/tradeoff.csv and one PNG per series (needs gnuplot)")
      ->type_name("DIR");
  std::vector<std::string> knobs = TradeoffKnobs();
  std::string knob_names;
  for (const std::string& k : knobs) knob_names += (knob_names.empty() ? "" : "|") + k;
  tradeoff->add_option("--knob", opt->knob, "sweep only this knob")
      ->type_name(knob_names)
      ->check(OneOf(knobs, "a knob"));
  SetHelpFooter(tradeoff,
                {{"graspsim bench tradeoff --quick --knob dt", "only the time step's sweep, fewer repetitions"},
                 {"graspsim bench tradeoff --quick --plot plots/", "every knob, with plots/tradeoff.csv and PNG plots"}},
                {{kExitOk, "every setting was measured"},
                 {kExitFailure, "a setting could not be measured"},
                 usage,
                 {kExitMissingTool, "the --plot folder cannot be written, or gnuplot is missing (tradeoff.csv is still written)"},
                 interrupted});
}

}  // namespace gs::app
