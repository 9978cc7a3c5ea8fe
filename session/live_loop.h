// The live application's threads (DESIGN.md, Threads):
//   receiver thread   UDP -> parser -> fingertip targets -> latest-value mailbox
//                     (each sample stamped with its arrival time)
//   simulation thread fixed rate (the scene's timestep, 1 kHz by default) on
//                     absolute deadlines: newest sample from the mailbox, one
//                     step, a snapshot into a second mailbox at the publish rate;
//                     counts overruns (a step that ends after its deadline)
//   calling thread    publishes snapshots on LCM and prints the status line
//   render thread     (with --frames/--video) draws the frame snapshots the
//                     simulation leaves in a fixed pool at the frame rate
//                     (FrameRecorder, ERecordMode::Live); never waited for
// The simulation thread never blocks on the others and does not allocate.
#pragma once

#include <string>
#include <vector>

#include "session/pacing.h"
#include "session/tracked_sim.h"
#include "tracking/tracker_health.h"
#include "tracking/udp_receiver.h"

namespace gs::app {

struct LiveOptions {
  tracking::UdpOptions udp;
  /// Non-empty: the datagrams come from this LCM channel at lcm_url
  /// (graspsim.dtrack_datagram_t, tracking/lcm_receiver.h) instead of UDP.
  std::string lcm_channel;
  double duration = 0.0;        ///< s; 0: until Ctrl-C
  double publish_rate = 100.0;  ///< Hz; 0: no publishing
  std::string lcm_url;          ///< empty: LCM's default
  bool status = true;           ///< status line (on a terminal: one updated line; otherwise a line every 5 s)
  bool quiet = false;           ///< neither the status line nor tracker events
  double silent_after_s = 0.25; ///< no datagram this long: the tracker is reported silent
  PacingOptions pacing;         ///< the simulation thread's scheduling (session/pacing.h); default normal
  /// A step has this fraction of the timestep from its beginning and must end at most
  /// as far into its slot (0: no limit; StepSchedule::BudgetS): the solver stops
  /// sweeping when the rest would not hold another sweep
  /// (WorldParams::step_time_budget_s), and the step counts as unconverged and as a
  /// budget stop. When the loop runs behind its schedule a step solves less (at least
  /// one sweep).
  double step_budget = 0.0;
  /// A step may begin this many timesteps before its slot (StepSchedule in session/pacing.h):
  /// a long step then uses what the steps before it left over instead of missing its
  /// deadline. A datagram is still applied by the first step that begins after its
  /// arrival; the simulated time runs up to this many timesteps ahead of the clock.
  int lead_steps = 1;
  bool skip_late_solves = false;  ///< WorldParams::budget_may_skip_solve while live runs
  /// Detect collisions in every step. Off: with a step budget, a step that follows one
  /// past its budget carries that step's contacts (WorldParams::carry_contacts_after_s).
  bool detect_every_step = false;
  /// threads the simulation steps on, its own included (TrackedSim::UseThreads),
  /// started by the simulation thread once it has its scheduling: on the other cores
  int threads = 1;
};

struct LiveStats {
  double wall_s = 0.0;
  int64_t steps = 0;
  int64_t overruns = 0;         ///< steps that ended after their deadline
  int64_t skipped_steps = 0;    ///< deadlines given up after falling more than 50 ms behind
  double step_median_ms = 0.0, step_p99_ms = 0.0, step_max_ms = 0.0;
  uint64_t datagrams = 0;       ///< received and parsed
  uint64_t samples_applied = 0; ///< taken from the mailbox by the simulation (the rest were stale)
  double tracker_hz = 0.0;      ///< received rate: (n - 1) / (last - first arrival)
  /// datagrams carrying every tracked object the scene needs (tracking::JudgeFrame), their
  /// rate as tracker_hz's, and the others: not DTrack at all, or without what is needed
  uint64_t good_datagrams = 0, not_dtrack = 0, missing = 0;
  uint64_t other_side = 0;      ///< of the missing, with the scene's hand of the other side
  int missing_code = -1;        ///< what the last missing one lacked first (tracking::MissingLabel)
  double good_hz = 0.0;
  std::string needs;            ///< what a good datagram carries: "hand 0", "bodies 1, 2"
  uint64_t foreign_messages = 0;  ///< LCM input: messages on the channel of another type
  double max_rise_m = 0.0;      ///< the scene's tracked body: highest rise above its start
  int max_contacts = 0;
  tracking::ParseStats parse;
  std::string last_parse_error;  ///< "line 3 (6d): object 1: ..." when there were errors
  uint64_t rejected_senders = 0;
  tracking::HealthCounts health;  ///< tracker events seen (silences, floods, ...)
  std::string tracker_state;      ///< at the end: ok, silent, flood, ...
  uint64_t published = 0;       ///< LCM messages (poses + contacts)
  bool lcm_ok = false;
  /// per applied sample: steps from the step in progress at its arrival to the
  /// step that applied it, and µs from arrival to the end of that step
  std::vector<int> latency_steps;
  std::vector<double> latency_us;
  /// with rendering (--frames/--video): frames drawn, and frame times dropped
  /// because the render thread was behind (the simulation never waits for it)
  int64_t frames_drawn = 0, frames_dropped = 0;
  PacingGrant pacing;           ///< what the OS granted the simulation thread
  int64_t unconverged_steps = 0;  ///< steps whose solve did not reach the scene's tolerance
  int64_t budget_stops = 0;       ///< of those, steps ended by the step budget
  int64_t skipped_solves = 0;     ///< of those, steps with no time left for a sweep (the last forces kept)
  int64_t carried_steps = 0;      ///< steps that carried the last contacts instead of detecting (WorldParams::carry_contacts_after_s)
  double residual_max = 0.0;      ///< largest solver error of a step that swept
  double sim_rate_hz() const { return wall_s > 0 ? static_cast<double>(steps) / wall_s : 0.0; }
  /// the datagrams judged as replay judges them (TrackedSim::tally)
  DatagramTally Tally() const {
    DatagramTally t;
    t.datagrams = datagrams;
    t.good = good_datagrams;
    t.not_dtrack = not_dtrack;
    t.missing = missing;
    t.other_side = other_side;
    t.missing_code = missing_code;
    return t;
  }
};

class FrameRecorder;

/// Opens live's tracker input: the UDP socket of opt.udp, or opt.lcm_channel on
/// opt.lcm_url; nullptr with *error naming what failed.
std::unique_ptr<tracking::DatagramSource> OpenLiveSource(const LiveOptions& opt, std::string* error);

/// Runs until the duration ends or Ctrl-C. False with a message when the
/// socket cannot be opened. `frames` (may be null): a started recorder in
/// ERecordMode::Live, fed on the simulation thread at its frame times.
bool RunLive(TrackedSim& sim, const LiveOptions& opt, LiveStats* stats, std::string* error,
             FrameRecorder* frames = nullptr);

}  // namespace gs::app
