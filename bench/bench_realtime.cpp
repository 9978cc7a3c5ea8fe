// `graspsim bench realtime [--json] [--seconds S] [--scene FILE] [--rt-priority N]
// [--cpu N] [--spin-us N] [--step-budget F] [--lead-steps N] [--skip-late-solves] [--steps-csv FILE]`: the
// performance target of issue 6. A tracked session
// of the paper's grasp (config/tracked_paper_grasp.yaml by default; the synthetic
// hand of `graspsim send --synthetic`: reach, close, lift, hold, release, its
// 2.9 s cycle looped to S seconds at 100 Hz) is replayed at the recorded pace:
// the replay's loop (cmd_replay.cpp: each datagram applies at its arrival in
// simulated time, TrackedSim steps) paced on absolute deadlines as in the live
// loop (live_loop.cpp and session/pacing.h: SCHED_FIFO on its own core; step k must
// end by start + (k+1) dt, and may begin --lead-steps timesteps before its slot,
// default 1: StepSchedule in session/pacing.h), with the live render thread (FrameRecorder in
// ERecordMode::Live: a fixed pool of snapshots, never waited for, nice 10, one
// llvmpipe thread, on the other cores) drawing 640x480 at 30 frames per
// simulated second into a null sink. Then the same without rendering, then an
// empty loop paced the same way (the machine's own misses). Reported per run:
// missed deadlines (steps that ended after their deadline), how many runs of
// consecutive late steps they make, the overlong steps (loop time over 1 ms) and the
// misses by cause (the step's own work, a late wake-up, catching up), the worst lateness, the wake-up lateness, the step's median, p99
// and max, frames drawn and dropped, the machine's load average. A late step is
// not skipped: the next starts at once (the replay catches up), so a missed
// deadline delays but never drops simulated time. As in live, each step has F
// timesteps from its beginning and ends at most F timesteps into its slot (default
// 0.8): the solver stops sweeping when the rest of that would not hold another sweep; such steps are counted (budget stops) with
// the largest solver error reached (the last sweep's estimate where the exact pass did
// not fit either: core/nsgs.h). --steps-csv writes every step of both runs
// (loop time, lateness, stage times, contacts, sweeps, the step's work counters)
// to see what made a step late.

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include "bench/bench.h"
#include "session/pacing.h"
#include "scene/paths.h"
#include "session/frame_recorder.h"
#include "session/tracked_sim.h"
#include "tracking/synthetic_hand.h"
#include "scene/exit_code.h"
#include "session/console.h"
#include "view/live_view.h"

namespace gs::app {
namespace {

constexpr double kTrackerHz = 100.0;

double LoadAverage() {
  double l = 0.0;
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf", &l) != 1) l = 0.0;
    std::fclose(f);
  }
  return l;
}

// Time the hypervisor ran something else while this core's virtual CPU was ready
// (/proc/stat's steal column, in clock ticks of 10 ms on most kernels: a coarse count,
// but one that shows the machine, not the loop, held the loop off): ms, or -1 when the
// kernel does not say. `cpu` -1: all cores together.
double StealMs(int cpu) {
  FILE* f = std::fopen("/proc/stat", "r");
  if (!f) return -1.0;
  char line[512];
  const std::string want = cpu < 0 ? "cpu " : "cpu" + std::to_string(cpu) + " ";
  double ms = -1.0;
  while (std::fgets(line, sizeof line, f)) {
    if (std::strncmp(line, want.c_str(), want.size()) != 0) continue;
    unsigned long long v[8] = {};
    if (std::sscanf(line + want.size(), "%llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3], &v[4],
                    &v[5], &v[6], &v[7]) == 8) {
      const long hz = sysconf(_SC_CLK_TCK);
      if (hz > 0) ms = 1e3 * static_cast<double>(v[7]) / static_cast<double>(hz);
    }
    break;
  }
  std::fclose(f);
  return ms;
}

double StealSince(double before, int cpu) {
  const double now = StealMs(cpu);
  return before < 0.0 || now < 0.0 ? -1.0 : now - before;
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5))];
}

// the session: the synthetic hand's cycle looped, one datagram every 10 ms
struct Session {
  std::vector<std::string> datagrams;
  std::vector<double> arrival_s;
};

Session MakeSession(double seconds, const tracking::SyntheticHand& hand) {
  Session s;
  const int n = static_cast<int>(std::ceil(seconds * kTrackerHz)) + 1;
  s.datagrams.reserve(n);
  s.arrival_s.reserve(n);
  for (int i = 0; i < n; ++i) {
    const double t = i / kTrackerHz;
    s.datagrams.push_back(hand.Datagram(std::fmod(t, hand.duration_s), static_cast<uint32_t>(i)));
    s.arrival_s.push_back(t);
  }
  return s;
}

// one step of a run, for --steps-csv
struct StepTrace {
  int64_t k = 0;
  double wake_ms = 0, loop_ms = 0, late_ms = 0;  // double: a slow (sanitized) run falls seconds behind, where a float's grain passes 0.1 us
  float free_motion = 0, traverse = 0, interpenetration = 0, refit = 0, fill_w_rigid = 0, fill_w_deform = 0,
        solve = 0, constrained_motion = 0, total = 0;  // ms
  int contacts = 0, iterations = 0, cache_hits = 0, cache_builds = 0, cache_refills = 0, slice_tests = 0;
  int projections = 0, fits = 0, feet_kept = 0, remembered = 0, far = 0;  // CollisionStats
  StepWork work;
  bool frame = false, budget_stopped = false, solve_skipped = false, carried = false;
  double residual = 0.0;
};

struct RunResult {
  bool render = false;
  int threads = 1;              ///< the step's threads (TrackedSim::UseThreads)
  int64_t view_requests = -1;   ///< --view: requests the live view served during the run (-1: no view)
  double dt = 0.0;
  int64_t steps = 0;
  int64_t missed = 0;           ///< steps that ended after their deadline
  int64_t late_runs = 0;        ///< runs of consecutive late steps (one delay makes a run while the replay catches up)
  int64_t overlong = 0;         ///< steps whose own loop time exceeded the period (late by their own work without
                                ///< a lead; with one, only once the lead is used up)
  // each missed deadline by its cause (the three add up to `missed`):
  int64_t missed_own = 0;       ///< the step's own work: it began in time for its whole budget and still ended late
  int64_t missed_woke_late = 0; ///< the machine: the previous step was on time, but this one began too late for
                                ///< its whole budget (StepSchedule::LatestBeginNs)
  int64_t missed_carried = 0;   ///< catching up: the previous step was late already
  double load_start = 0, load_end = 0;  ///< the machine's 1-minute load average before and after
  double steal_ms = -1.0;       ///< the hypervisor's steal time on the loop's core over the run (-1: unknown)
  double worst_late_ms = 0.0;   ///< largest (end - deadline)
  double step_median_ms = 0, step_p99_ms = 0, step_max_ms = 0;  ///< World::Step
  double loop_median_ms = 0, loop_p99_ms = 0;                   ///< datagrams + step + snapshot
  double wake_p99_ms = 0, wake_max_ms = 0;  ///< how late the loop woke after each step's start time
  double wall_s = 0.0;
  std::string pacing;           ///< what the OS granted the loop (PacingGrant::Describe)
  std::string refused;
  int frames_taken = 0, frames_drawn = 0, frames_dropped = 0;
  int max_contacts = 0;
  int64_t unconverged = 0;      ///< steps whose solve did not reach the scene's tolerance
  int64_t budget_stops = 0;     ///< of those, ended by the step budget
  int64_t skipped_solves = 0;   ///< of those, steps left no time for a sweep (the warm start stood)
  int64_t carried_steps = 0;    ///< steps that carried the last step's contacts (WorldParams::carry_contacts_after_s)
  double residual_max = 0.0;    ///< largest solver error of a step (estimated where the budget stopped it)
  int lifts = 0;                ///< cycles in which the box rose 2 cm above its start
  std::vector<double> lift_s;   ///< when each of them rose (simulated s)
  /// the lifts before simulated time t
  int lifts_in(double t) const {
    return static_cast<int>(std::count_if(lift_s.begin(), lift_s.end(), [t](double x) { return x < t; }));
  }
  size_t datagrams = 0;
  std::vector<StepTrace> trace;  ///< every step, when asked for
};

bool RunOnce(const std::string& scene, const Session& session, double seconds, bool render, const PacingOptions& po,
             int threads, const BenchOptions& opt, bool trace, const std::string& view_address,
             RunResult* out, std::string* error) {
  auto sim = std::make_unique<TrackedSim>();
  tracking::SyntheticHand aimed;  // the session's, already made: only the scene's start pose matters here
  std::string moved;
  if (!LoadForSyntheticHand(scene, sim.get(), &aimed, &moved, error)) return false;
  World& w = sim->world();
  const int lead = opt.lead_steps;
  const double step_budget = opt.step_budget;
  w.params.budget_may_skip_solve = opt.skip_late_solves;
  const double dt = w.params.dt;
  w.params.carry_contacts_after_s = CarryContactsAfter(step_budget, opt.detect_every_step, dt);
  const int64_t steps = static_cast<int64_t>(std::llround(seconds / dt));
  RenderOptions ro;
  ro.discard = render;  // draw every frame time, write nothing
  ro.avoid_cpu = po.cpu;
  // --view: the live view reads the rendering run's snapshots, as in live
  view::LiveView live_view;
  const bool view = render && !view_address.empty();
  if (view && !live_view.Start(view_address, sim->scene(), error, po.cpu)) return false;
  if (view) ro.reader = &live_view;
  FrameRecorder recorder;
  if (!recorder.Start(ro, sim->scene(), error, ERecordMode::Live)) return false;
  const int tracked = sim->scene().tracked_body;
  const double z0 = tracked >= 0 ? w.bodies[tracked].pose.t.z() : 0.0;
  std::vector<double> step_ms, loop_ms, wake_ms;
  step_ms.reserve(static_cast<size_t>(steps));
  loop_ms.reserve(static_cast<size_t>(steps));
  wake_ms.reserve(static_cast<size_t>(steps));
  out->lift_s.reserve(static_cast<size_t>(seconds) + 8);  // at most one lift a second
  tracking::TargetSample sample;
  char tracker_text[160] = "";
  size_t next = 0;
  bool lifted = false;
  const int64_t period = static_cast<int64_t>(std::llround(dt * 1e9));
  *out = RunResult();
  if (trace) out->trace.reserve(static_cast<size_t>(steps));
  out->render = render;
  out->dt = dt;
  // after the render thread started, so that it keeps normal scheduling
  const PacingGrant grant = EnterRealtime(po);
  sim->UseThreads(threads);  // after the loop's scheduling: the workers take it, on the other cores
  out->threads = threads;
  out->pacing = grant.Describe();
  out->refused = grant.refused;
  StepSchedule schedule;
  schedule.start_ns = MonotonicNs() + (2 + lead) * period;
  schedule.period_ns = period;
  schedule.lead = lead;
  out->load_start = LoadAverage();
  const double steal_start = StealMs(po.cpu);
  bool was_late = false;
  for (int64_t k = 0; k < steps; ++k) {
    if (StopRequested()) {  // Ctrl-C: a session cut short is no measurement
      *error = "interrupted at step " + std::to_string(k) + " of " + std::to_string(steps) + "; nothing reported";
      return false;
    }
    WaitUntilNs(schedule.ReleaseNs(k), po.spin_ns);
    const int64_t begin = MonotonicNs();
    wake_ms.push_back(1e-6 * static_cast<double>(begin - schedule.ReleaseNs(k)));
    // every datagram that arrived by now applies from this step on (as in replay)
    while (next < session.datagrams.size() && session.arrival_s[next] <= w.time + 1e-12) {
      const std::string& d = session.datagrams[next];
      sim->Ingest(d.data(), d.size(), false, &sample);
      sample.sequence = next;
      sim->Push(sample);
      ++next;
    }
    if (step_budget > 0.0)  // as in live (session/pacing.h): step_budget of a timestep, never past as far into its slot
      w.params.step_time_budget_s = schedule.BudgetS(k, begin, step_budget);
    sim->Step();
    out->unconverged += w.profile.converged ? 0 : 1;
    out->budget_stops += w.profile.budget_stopped ? 1 : 0;
    out->skipped_solves += w.profile.solve_skipped ? 1 : 0;
    out->carried_steps += w.profile.contacts_carried ? 1 : 0;
    if (!w.profile.solve_skipped) out->residual_max = std::max(out->residual_max, w.profile.residual);
    const bool frame = recorder.FrameDue(w);
    if (frame) sim->HudText(tracker_text, sizeof tracker_text);
    recorder.AfterStep(w, tracker_text);
    const int64_t end = MonotonicNs();
    const int64_t late = end - schedule.DeadlineNs(k);
    if (end - begin > period) ++out->overlong;
    const bool prev_late = was_late;
    if (late > 0 && !was_late) ++out->late_runs;
    was_late = late > 0;
    if (late > 0) {
      ++out->missed;
      out->worst_late_ms = std::max(out->worst_late_ms, 1e-6 * static_cast<double>(late));
      if (end - begin <= period && prev_late)
        ++out->missed_carried;
      else if (end - begin <= period && begin > schedule.LatestBeginNs(k, step_budget))
        ++out->missed_woke_late;
      else
        ++out->missed_own;
    }
    if (trace) {
      const StepProfile& p = w.profile;
      StepTrace t;
      t.k = k;
      t.wake_ms = wake_ms.back();
      t.loop_ms = 1e-6 * static_cast<double>(end - begin);
      t.late_ms = 1e-6 * static_cast<double>(late);
      t.free_motion = static_cast<float>(1e3 * p.free_motion);
      t.traverse = static_cast<float>(1e3 * p.traverse);
      t.interpenetration = static_cast<float>(1e3 * p.interpenetration);
      t.refit = static_cast<float>(1e3 * p.refit);
      t.fill_w_rigid = static_cast<float>(1e3 * p.fill_w_rigid);
      t.fill_w_deform = static_cast<float>(1e3 * p.fill_w_deform);
      t.solve = static_cast<float>(1e3 * p.solve);
      t.constrained_motion = static_cast<float>(1e3 * p.constrained_motion);
      t.total = static_cast<float>(1e3 * p.total);
      t.contacts = p.contacts;
      t.iterations = p.iterations;
      t.cache_hits = p.collision.cache_hits;
      t.cache_builds = p.collision.cache_builds;
      t.cache_refills = p.collision.cache_refills;
      t.slice_tests = p.collision.slice_tests;
      t.projections = p.collision.projections;
      t.fits = p.collision.fits;
      t.feet_kept = p.collision.feet_kept;
      t.remembered = p.collision.remembered;
      t.far = p.collision.far;
      t.work = p.work;
      t.frame = frame;
      t.budget_stopped = p.budget_stopped;
      t.solve_skipped = p.solve_skipped;
      t.carried = p.contacts_carried;
      t.residual = p.residual;
      out->trace.push_back(t);
    }
    step_ms.push_back(1e3 * w.profile.total);
    loop_ms.push_back(1e-6 * static_cast<double>(end - begin));
    out->max_contacts = std::max(out->max_contacts, w.profile.contacts);
    if (tracked >= 0) {
      const bool up = w.bodies[tracked].pose.t.z() - z0 >= 0.02;
      if (up && !lifted) {
        ++out->lifts;
        out->lift_s.push_back(w.time);
      }
      lifted = up;
    }
  }
  out->wall_s = 1e-9 * static_cast<double>(MonotonicNs() - schedule.ReleaseNs(0));
  out->steal_ms = StealSince(steal_start, po.cpu);
  LeaveRealtime();
  out->load_end = LoadAverage();
  out->steps = steps;
  out->datagrams = next;
  out->frames_taken = recorder.frames_taken();
  if (!recorder.Finish(error, true)) return false;
  out->frames_drawn = recorder.frames_drawn();
  out->frames_dropped = recorder.frames_dropped();
  if (view) {
    out->view_requests = live_view.requests();
    live_view.Stop(true);
  }
  out->step_median_ms = Percentile(step_ms, 0.5);
  out->step_p99_ms = Percentile(step_ms, 0.99);
  out->step_max_ms = step_ms.empty() ? 0.0 : *std::max_element(step_ms.begin(), step_ms.end());
  out->loop_median_ms = Percentile(loop_ms, 0.5);
  out->loop_p99_ms = Percentile(loop_ms, 0.99);
  out->wake_p99_ms = Percentile(wake_ms, 0.99);
  out->wake_max_ms = wake_ms.empty() ? 0.0 : *std::max_element(wake_ms.begin(), wake_ms.end());
  return true;
}

// the platform's own share: the same paced loop doing no work (cyclictest's
// measurement), so that the misses of a run can be told from the machine's
struct EmptyResult {
  int64_t steps = 0, missed = 0, late_runs = 0;
  double worst_late_ms = 0.0, wake_p99_ms = 0.0, wake_max_ms = 0.0;
  double steal_ms = -1.0;
};

EmptyResult RunEmpty(double seconds, double dt, const PacingOptions& po, int lead) {
  EmptyResult r;
  r.steps = static_cast<int64_t>(std::llround(seconds / dt));
  std::vector<double> wake_ms;
  wake_ms.reserve(static_cast<size_t>(r.steps));
  EnterRealtime(po);
  StepSchedule schedule;
  schedule.period_ns = static_cast<int64_t>(std::llround(dt * 1e9));
  schedule.start_ns = MonotonicNs() + (2 + lead) * schedule.period_ns;
  schedule.lead = lead;
  const double steal_start = StealMs(po.cpu);
  bool was_late = false;
  for (int64_t k = 0; k < r.steps && !StopRequested(); ++k) {
    WaitUntilNs(schedule.ReleaseNs(k), po.spin_ns);
    const int64_t end = MonotonicNs();
    wake_ms.push_back(1e-6 * static_cast<double>(end - schedule.ReleaseNs(k)));
    const int64_t late = end - schedule.DeadlineNs(k);
    if (late > 0 && !was_late) ++r.late_runs;
    was_late = late > 0;
    if (late > 0) {
      ++r.missed;
      r.worst_late_ms = std::max(r.worst_late_ms, 1e-6 * static_cast<double>(late));
    }
  }
  r.steal_ms = StealSince(steal_start, po.cpu);
  LeaveRealtime();
  r.wake_p99_ms = Percentile(wake_ms, 0.99);
  r.wake_max_ms = wake_ms.empty() ? 0.0 : *std::max_element(wake_ms.begin(), wake_ms.end());
  return r;
}

// both runs' traces as CSV into `f` (opened on path + ".tmp" before the runs, so
// that a path that cannot be written is said at once), renamed over `path` once whole
bool WriteTrace(FILE* f, const std::string& path, const RunResult& with, const RunResult& without,
                std::string* error) {
  const std::string tmp = path + ".tmp";
  std::fprintf(f, "rendering,step,wake_ms,loop_ms,late_ms,free_motion_ms,traverse_ms,interpenetration_ms,refit_ms,"
                  "fill_w_rigid_ms,fill_w_deform_ms,solve_ms,constrained_motion_ms,step_ms,contacts,sweeps,"
                  "cache_hits,cache_builds,frame,budget_stop,node_tests,w_blocks_built,w_deform_sides,"
                  "w_deform_reused,w_deform_direct,weights_reused,deformed_points,bodies_asleep,contacts_reused,"
                  "cache_refills,slice_tests,solve_skipped,residual,carried_contacts,projections,fits,feet_kept,"
                  "remembered,far_stops\n");
  for (const RunResult* r : {&with, &without}) {
    for (const StepTrace& t : r->trace) {
      std::fprintf(f, "%d,%lld,%.6f,%.6f,%.6f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%d,%d,%d,%d,%d,%d,",
                   r->render ? 1 : 0, static_cast<long long>(t.k), t.wake_ms, t.loop_ms, t.late_ms, t.free_motion,
                   t.traverse, t.interpenetration, t.refit, t.fill_w_rigid, t.fill_w_deform, t.solve,
                   t.constrained_motion, t.total, t.contacts, t.iterations, t.cache_hits, t.cache_builds,
                   t.frame ? 1 : 0, t.budget_stopped ? 1 : 0);
      const StepWork& k = t.work;
      std::fprintf(f, "%d,%d,%d,%d,%d,%d,%d,%d,%d,%d,%d,%d,%.3g,%d,", k.node_tests, k.w_blocks_built, k.w_deform_sides,
                   k.w_deform_reused, k.w_deform_direct, k.weights_reused, k.deformed_points, k.bodies_asleep,
                   k.contacts_reused, t.cache_refills, t.slice_tests, t.solve_skipped ? 1 : 0, t.residual,
                   t.carried ? 1 : 0);
      std::fprintf(f, "%d,%d,%d,%d,%d\n", t.projections, t.fits, t.feet_kept, t.remembered, t.far);
    }
  }
  const bool ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
    *error = "cannot write --steps-csv file " + path + ": " + std::strerror(errno);
    std::remove(tmp.c_str());
    return false;
  }
  return true;
}

void PrintJson(const RunResult& r, double seconds) {
  std::printf("{\"bench\":\"realtime\",\"rendering\":%s,\"threads\":%d,\"seconds\":%g,\"steps\":%lld,\"missed_deadlines\":%lld,"
              "\"late_runs\":%lld,\"overlong_steps\":%lld,\"missed_own_work\":%lld,\"missed_woke_late\":%lld,"
              "\"missed_carried\":%lld,"
              "\"worst_lateness_ms\":%.4f,\"step_ms_median\":%.4f,\"step_ms_p99\":%.4f,\"step_ms_max\":%.4f,"
              "\"loop_ms_median\":%.4f,\"loop_ms_p99\":%.4f,\"wall_s\":%.3f,\"frames\":%d,\"frames_taken\":%d,"
              "\"frames_dropped\":%d,\"max_contacts\":%d,\"unconverged_steps\":%lld,\"budget_stops\":%lld,"
              "\"skipped_solves\":%lld,\"carried_contact_steps\":%lld,\"residual_max\":%.3g,\"lifts\":%d,\"datagrams\":%zu,"
              "\"wake_ms_p99\":%.4f,\"wake_ms_max\":%.4f,\"pacing\":\"%s\",\"pacing_refused\":\"%s\","
              "\"load_average_start\":%.2f,\"load_average_end\":%.2f,\"steal_ms\":%.0f}\n",
              r.render ? "true" : "false", r.threads, seconds, static_cast<long long>(r.steps), static_cast<long long>(r.missed),
              static_cast<long long>(r.late_runs), static_cast<long long>(r.overlong), static_cast<long long>(r.missed_own),
              static_cast<long long>(r.missed_woke_late), static_cast<long long>(r.missed_carried), r.worst_late_ms,
              r.step_median_ms, r.step_p99_ms, r.step_max_ms, r.loop_median_ms, r.loop_p99_ms,
              r.wall_s, r.frames_drawn, r.frames_taken, r.frames_dropped, r.max_contacts, static_cast<long long>(r.unconverged),
              static_cast<long long>(r.budget_stops), static_cast<long long>(r.skipped_solves),
              static_cast<long long>(r.carried_steps), r.residual_max, r.lifts, r.datagrams, r.wake_p99_ms,
              r.wake_max_ms, r.pacing.c_str(), r.refused.c_str(), r.load_start, r.load_end, r.steal_ms);
}

}  // namespace

int RunBenchRealtime(const BenchOptions& opt) {
  const double seconds = opt.seconds > 0 ? opt.seconds : (opt.quick ? 2.0 : 60.0);
  const std::string scene = ResolveResource(opt.scene.empty() ? "config/tracked_paper_grasp.yaml" : opt.scene);
  // the synthetic hand the scene's tracker follows (the whole hand for a tracked hand)
  tracking::SyntheticHand hand;
  {
    TrackedSim aimed;
    std::string moved, ignored;  // a scene that cannot load fails in RunOnce, with its error
    if (LoadForSyntheticHand(scene, &aimed, &hand, &moved, &ignored) && !moved.empty() && !opt.json)
      std::printf("%s\n", moved.c_str());
    hand.pinch = opt.pinch && hand.whole_hand;
  }
  const Session session = MakeSession(seconds, hand);
  if (!opt.json)
    std::printf("graspsim bench realtime: %s, the synthetic hand's grasp cycle looped over %g s at %g Hz, replayed at "
                "the recorded pace; 1 kHz deadlines; rendering 640x480 at 30 fps to a null sink, then without\n",
                scene.c_str(), seconds, kTrackerHz);
  RunResult with, without;
  EmptyResult empty;
  std::string error;
  PacingOptions po;
  po.priority = opt.rt_priority;
  std::string moved;
  po.cpu = opt.cpu_given ? opt.cpu : ChooseCore(opt.cpu, &moved);
  if (!moved.empty()) std::fprintf(stderr, "bench realtime: %s\n", moved.c_str());
  po.spin_ns = static_cast<int64_t>(std::llround(opt.spin_us * 1e3));
  const bool trace = !opt.steps_csv.empty();
  FILE* trace_file = nullptr;
  if (trace && !(trace_file = std::fopen((opt.steps_csv + ".tmp").c_str(), "w"))) {
    std::fprintf(stderr, "bench realtime: cannot write --steps-csv file %s.tmp: %s\n", opt.steps_csv.c_str(),
                 std::strerror(errno));
    return 3;
  }
  const int threads = WorkerPool::ThreadsFor(opt.threads);
  if (!RunOnce(scene, session, seconds, true, po, threads, opt, trace, opt.view, &with, &error) ||
      !RunOnce(scene, session, seconds, false, po, threads, opt, trace, "", &without, &error) ||
      (trace && !WriteTrace(std::exchange(trace_file, nullptr), opt.steps_csv, with, without, &error))) {
    if (trace_file) {  // a run failed: the trace is not written
      std::fclose(trace_file);
      std::remove((opt.steps_csv + ".tmp").c_str());
    }
    std::fprintf(stderr, "bench realtime: %s\n", error.c_str());
    return StopRequested() ? kExitInterrupted : kExitBadInput;
  }
  empty = RunEmpty(seconds, with.dt, po, opt.lead_steps);
  if (StopRequested()) {
    std::fprintf(stderr, "bench realtime: interrupted during the empty loop; nothing reported\n");
    return kExitInterrupted;
  }
  if (opt.json) {
    PrintJson(without, seconds);
    PrintJson(with, seconds);
    std::printf("{\"bench\":\"realtime\",\"empty_loop\":true,\"seconds\":%g,\"steps\":%lld,\"missed_deadlines\":%lld,"
                "\"late_runs\":%lld,\"worst_lateness_ms\":%.4f,\"wake_ms_p99\":%.4f,\"wake_ms_max\":%.4f,"
                "\"steal_ms\":%.0f}\n",
                seconds, static_cast<long long>(empty.steps), static_cast<long long>(empty.missed),
                static_cast<long long>(empty.late_runs), empty.worst_late_ms, empty.wake_p99_ms, empty.wake_max_ms,
                empty.steal_ms);
    std::printf("{\"bench\":\"realtime\",\"seconds\":%g,\"steps\":%lld,\"missed_deadlines\":%lld,"
                "\"late_runs\":%lld,\"overlong_steps\":%lld,\"missed_own_work\":%lld,\"missed_woke_late\":%lld,"
                "\"missed_carried\":%lld,\"no_render_missed_own_work\":%lld,"
                "\"worst_lateness_ms\":%.4f,\"step_ms_median\":%.4f,\"step_ms_p99\":%.4f,\"frames\":%d,"
                "\"frames_dropped\":%d,\"no_render_missed_deadlines\":%lld,\"no_render_worst_lateness_ms\":%.4f,"
                "\"no_render_step_ms_median\":%.4f,\"empty_loop_missed_deadlines\":%lld,\"empty_loop_late_runs\":%lld,"
                "\"unconverged_steps\":%lld,\"budget_stops\":%lld,\"skipped_solves\":%lld,\"carried_contact_steps\":%lld,"
                "\"no_render_carried_contact_steps\":%lld,\"step_budget\":%g,"
                "\"lead_steps\":%d,\"view_requests\":%lld,\"pacing\":\"%s\",\"target_met\":%s}\n",
                seconds, static_cast<long long>(with.steps), static_cast<long long>(with.missed),
                static_cast<long long>(with.late_runs), static_cast<long long>(with.overlong),
                static_cast<long long>(with.missed_own), static_cast<long long>(with.missed_woke_late),
                static_cast<long long>(with.missed_carried), static_cast<long long>(without.missed_own),
                with.worst_late_ms, with.step_median_ms, with.step_p99_ms, with.frames_drawn, with.frames_dropped,
                static_cast<long long>(without.missed), without.worst_late_ms, without.step_median_ms,
                static_cast<long long>(empty.missed), static_cast<long long>(empty.late_runs),
                static_cast<long long>(with.unconverged), static_cast<long long>(with.budget_stops),
                static_cast<long long>(with.skipped_solves), static_cast<long long>(with.carried_steps),
                static_cast<long long>(without.carried_steps), opt.step_budget, opt.lead_steps,
                static_cast<long long>(with.view_requests), with.pacing.c_str(), with.missed == 0 && with.step_median_ms <= 1.0 ? "true" : "false");
    return 0;
  }
  std::printf("  %-18s %8s %8s %6s %8s %10s %9s %9s %9s %9s %9s %9s %8s %8s %8s\n", "", "steps", "missed", "runs", "overlong", "worst late", "step med",
              "step p99", "step max", "loop p99", "wake p99", "wake max", "frames", "dropped", "contacts");
  for (const RunResult* r : {&with, &without})
    std::printf("  %-18s %8lld %8lld %6lld %8lld %7.3f ms %6.3f ms %6.3f ms %6.3f ms %6.3f ms %6.3f ms %6.3f ms %8d %8d %8d\n",
                r->render ? "with rendering" : "without rendering", static_cast<long long>(r->steps),
                static_cast<long long>(r->missed), static_cast<long long>(r->late_runs),
                static_cast<long long>(r->overlong), r->worst_late_ms, r->step_median_ms, r->step_p99_ms, r->step_max_ms,
                r->loop_p99_ms, r->wake_p99_ms, r->wake_max_ms, r->frames_drawn, r->frames_dropped, r->max_contacts);
  std::printf("  %-18s %8lld %8lld %6lld %8s %7.3f ms %9s %9s %9s %9s %6.3f ms %6.3f ms\n", "empty loop",
              static_cast<long long>(empty.steps), static_cast<long long>(empty.missed),
              static_cast<long long>(empty.late_runs), "-", empty.worst_late_ms, "-", "-", "-", "-", empty.wake_p99_ms,
              empty.wake_max_ms);
  std::printf("  (empty loop: the same pacing with no step, the machine's own misses)\n");
  for (const RunResult* r : {&with, &without})
    std::printf("  %s: missed deadlines by cause: %lld the step's own work, %lld began too late for their whole budget (the machine "
                "woke the loop late), %lld catching up after a late step\n",
                r->render ? "with rendering" : "without rendering", static_cast<long long>(r->missed_own),
                static_cast<long long>(r->missed_woke_late), static_cast<long long>(r->missed_carried));
  std::printf("  simulation thread: %s%s%s; spin %.0f us before each wake-up; a step may begin %d timestep%s "
              "before its slot (--lead-steps)\n",
              with.pacing.c_str(), with.refused.empty() ? "" : "; ", with.refused.c_str(), opt.spin_us, opt.lead_steps,
              opt.lead_steps == 1 ? "" : "s");
  for (const RunResult* r : {&with, &without})
    std::printf("  %s: %lld steps unconverged, %lld of them stopped by the step budget (%g of a timestep%s), %lld of those with no time left for a sweep (the last forces kept); largest solver "
                "error %.3g (of the steps that swept)\n",
                r->render ? "with rendering" : "without rendering", static_cast<long long>(r->unconverged),
                static_cast<long long>(r->budget_stops), opt.step_budget, opt.step_budget > 0 ? "" : ": no budget",
                static_cast<long long>(r->skipped_solves), r->residual_max);
  for (const RunResult* r : {&with, &without})
    std::printf("  %s: %lld steps carried the last step's contacts after a step past its budget (%s)\n",
                r->render ? "with rendering" : "without rendering", static_cast<long long>(r->carried_steps),
                opt.detect_every_step || opt.step_budget <= 0 ? "off: detection in every step" : "--detect-every-step turns it off");
  std::printf("  load average %.2f -> %.2f (rendering run), %.2f -> %.2f (without)\n", with.load_start, with.load_end,
              without.load_start, without.load_end);
  std::printf("  the hypervisor's steal time on the loop's core (/proc/stat, 10 ms ticks; -1: not said): %.0f ms "
              "(rendering run), %.0f ms (without), %.0f ms (empty loop)\n",
              with.steal_ms, without.steal_ms, empty.steal_ms);
  // a last cycle cut short by --seconds is not counted: it may end before its lift
  const int whole_cycles = static_cast<int>(std::floor(seconds / hand.duration_s + 1e-9));
  const double cut = seconds - whole_cycles * hand.duration_s;
  char cut_text[96] = "";
  if (cut > 1e-9) std::snprintf(cut_text, sizeof cut_text, " (the last %.1f s, a cycle cut short, not counted)", cut);
  std::printf("  the box was lifted in %d of %d whole grasp cycles of %.1f s, with rendering, %d without%s; target (no "
              "missed deadline, step median <= 1 ms): %s\n",
              with.lifts_in(whole_cycles * hand.duration_s), whole_cycles, hand.duration_s,
              without.lifts_in(whole_cycles * hand.duration_s),
              cut_text,
              with.missed == 0 && with.step_median_ms <= 1.0 ? "met" : "NOT met");
  return 0;
}

}  // namespace gs::app
