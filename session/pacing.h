// Pacing of the fixed-rate simulation loop (live, bench realtime): what the
// operating system is asked for so that a step wakes on time, and the wait
// itself.
//
// A 1 kHz loop whose step takes 0.1 ms still misses deadlines when the thread
// wakes late: under normal scheduling (SCHED_OTHER) a runnable render or
// compiler thread, the timer slack (50 µs by default) and page faults each
// delay the wake-up. EnterRealtime asks, for the calling thread only:
//   - SCHED_FIFO at `priority` (needs CAP_SYS_NICE or an RLIMIT_RTPRIO grant;
//     the kernel still keeps 5% of each second for other tasks), so that no
//     normal thread delays its wake-up;
//   - a timer slack of 1 ns;
//   - mlockall of the pages mapped now and later (needs CAP_IPC_LOCK or an
//     unlimited RLIMIT_MEMLOCK: with a finite limit MCL_FUTURE could make a
//     later allocation fail, so only the current pages are locked then).
// What is refused is said in `refused`; the loop then runs with what it got.
// On a one-core machine none of it is asked: a real-time loop falling behind
// would starve the receiver and publisher threads of the only core.
// Threads started afterwards by this thread inherit its policy, so start the
// render thread first (FrameRecorder::Start) or give it its own.
#pragma once

#include <cstdint>
#include <string>

namespace gs::app {

struct PacingOptions {
  int priority = 0;       ///< SCHED_FIFO priority 1..99 for the simulation thread; 0: normal scheduling
  bool lock_memory = true;  ///< with priority > 0: mlockall
  int64_t spin_ns = 0;    ///< busy-wait the last spin_ns before each deadline instead of sleeping through it
  int cpu = -1;           ///< pin the simulation thread to this core (-1: anywhere; ignored on a 1-core machine)
};

struct PacingGrant {
  bool fifo = false;           ///< SCHED_FIFO granted
  int priority = 0;
  bool memory_locked = false;  ///< current (and, where allowed, future) pages locked
  int cpu = -1;                ///< the core the thread was pinned to
  std::string refused;         ///< what the OS refused and why ("" when everything asked was granted)
  /// "SCHED_FIFO 50, memory locked" / "normal scheduling" etc.
  std::string Describe() const;
};

/// The process-wide part of `opt`: mlockall, when EnterRealtime would ask for it
/// (a priority, a second core, no sanitizer). Locking a large process takes a
/// while (hundreds of ms): call it before the loop's clock starts and hand the
/// result to EnterRealtime.
PacingGrant LockMemory(const PacingOptions& opt);

/// Applies `opt` to the calling thread (see above). `locked`: what LockMemory
/// already did (null: locks here).
PacingGrant EnterRealtime(const PacingOptions& opt, const PacingGrant* locked = nullptr);

/// Claims `cpu` for this process's simulation loop: an advisory lock on the file
/// `dir`/graspsim-core-<cpu>.lock, held until the process exits. Two real-time loops
/// pinned to one core hold each other off it (a loop running behind never sleeps):
/// "" when the core was free or is already this process's, else a message naming the
/// process that holds it. EnterRealtime claims the core it pins to and says so in
/// `refused`; the loop runs anyway.
std::string ClaimCore(int cpu, const std::string& dir = "/tmp");

/// The core for a simulation loop whose core the user did not name (no --cpu):
/// `preferred` when no other graspsim loop has claimed it. Else, when at least two
/// cores are free, the lowest of them, claimed here for this process, so that the two
/// loops do not hold each other off one core while a core stays free for normal
/// threads (the tracker's receiver, the renderer, the tracker's sender on the same
/// machine). With fewer free cores (a second loop on a two-core machine), `preferred`:
/// a real-time loop on the last free core would starve everything else. `note` says
/// what happened whenever the preferred core was taken. `cpus` (0: the online count)
/// is for tests. -1 or a one-core machine: `preferred`, nothing said.
int ChooseCore(int preferred, std::string* note, const std::string& dir = "/tmp", int cpus = 0);

/// Back to normal scheduling for the calling thread (memory stays locked until exit).
void LeaveRealtime();

/// The fixed-rate loop's schedule. Step k simulates [k dt, (k+1) dt) and must end by
/// its deadline, start + (k+1) dt: the wall-clock time its simulated end stands for.
/// It may begin `lead` timesteps before its own slot, at start + (k - lead) dt. With
/// lead 0 a step has its slot and nothing more; with lead 1 a step that runs long
/// (a slow stretch of the machine, a hard contact configuration) uses the time the
/// steps before it left over instead of missing its deadline. A recorded session's
/// datagrams apply by simulated time, so the lead changes no replayed input; live,
/// a datagram is applied by the first step that begins after it arrived, as without
/// the lead, so the wall-clock time from its arrival to the state that holds it is the
/// same; only the state's simulated time is up to `lead` timesteps ahead of the clock.
struct StepSchedule {
  int64_t start_ns = 0;
  int64_t period_ns = 1000000;
  int lead = 0;
  /// the earliest step k begins
  int64_t ReleaseNs(int64_t k) const { return start_ns + (k - lead) * period_ns; }
  /// step k is late when it ends after this
  int64_t DeadlineNs(int64_t k) const { return start_ns + (k + 1) * period_ns; }
  /// The step budget (WorldParams::step_time_budget_s) of step k begun at `begin_ns`:
  /// `fraction` of a timestep from its beginning, and never past `fraction` of a timestep
  /// into its own slot (so a late step solves less, and a step begun early does not spend
  /// its lead); at least 1 ns (one sweep). Steps stay within the rate on average.
  double BudgetS(int64_t k, int64_t begin_ns, double fraction) const;
  /// the latest begin that leaves step k its whole budget (a later begin is the machine's
  /// doing: the loop woke late)
  int64_t LatestBeginNs(int64_t k, double fraction) const;
};

/// WorldParams::carry_contacts_after_s of a loop paced with this step budget (a
/// fraction of the timestep dt): a step whose own work took longer than its budget's
/// share of a timestep is followed by one that carries its contacts instead of
/// detecting them; 0 (detect in every step) without a budget or with
/// `detect_every_step`.
double CarryContactsAfter(double step_budget, bool detect_every_step, double dt);

/// CLOCK_MONOTONIC in nanoseconds.
int64_t MonotonicNs();

/// Sleeps until the absolute CLOCK_MONOTONIC time `ns`, the last `spin_ns` of it
/// busy-waiting (0: sleeps all the way). Returns at once when `ns` has passed.
void WaitUntilNs(int64_t ns, int64_t spin_ns = 0);

}  // namespace gs::app
