#include "session/pacing.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define GS_SPIN_PAUSE() _mm_pause()
#else
#define GS_SPIN_PAUSE() ((void)0)
#endif

namespace gs::app {

std::string PacingGrant::Describe() const {
  std::string s = fifo ? "SCHED_FIFO " + std::to_string(priority) : std::string("normal scheduling");
  if (memory_locked) s += ", memory locked";
  if (cpu >= 0) s += ", core " + std::to_string(cpu);
  return s;
}

namespace {

// SCHED_FIFO is asked only with a priority and a second core: a real-time loop
// that falls behind would starve the receiver and the publisher of the only core
bool AsksRealtime(const PacingOptions& opt) { return opt.priority > 0 && sysconf(_SC_NPROCESSORS_ONLN) >= 2; }

void Append(std::string* to, const std::string& what) {
  if (what.empty()) return;
  if (!to->empty()) *to += "; ";
  *to += what;
}

}  // namespace

namespace {

std::mutex claims_mu;
std::map<std::string, int> claims_held;  // lock file -> its descriptor, open until exit

std::string ClaimPath(int cpu, const std::string& dir) { return dir + "/graspsim-core-" + std::to_string(cpu) + ".lock"; }

// whether another process holds the claim on `cpu` (a probe: the lock is let go at once)
bool ClaimedElsewhere(int cpu, const std::string& dir) {
  const std::string path = ClaimPath(cpu, dir);
  {
    std::lock_guard<std::mutex> lock(claims_mu);
    if (claims_held.count(path)) return false;
  }
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;  // never claimed (or unreadable: no check, as in ClaimCore)
  const bool free = flock(fd, LOCK_EX | LOCK_NB) == 0;
  close(fd);  // lets the probe's lock go
  return !free;
}

}  // namespace

std::string ClaimCore(int cpu, const std::string& dir) {
  auto& held = claims_held;
  const std::string path = ClaimPath(cpu, dir);
  std::lock_guard<std::mutex> lock(claims_mu);
  if (held.count(path)) return "";
  // any user may lock it (flock needs only a descriptor): created readable and writable by all
  int fd = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (fd >= 0) fchmod(fd, 0666);
  if (fd < 0) fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "";  // no lock file, no check (the claim is a courtesy, not a requirement)
  if (flock(fd, LOCK_EX | LOCK_NB) == 0) {
    held[path] = fd;
    const std::string pid = std::to_string(getpid()) + "\n";
    if (ftruncate(fd, 0) == 0 && write(fd, pid.data(), pid.size()) < 0) {
      // a read-only lock file keeps the claim without the pid
    }
    return "";
  }
  char buf[32] = {};
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  close(fd);
  const long other = n > 0 ? std::strtol(buf, nullptr, 10) : 0;
  return "core " + std::to_string(cpu) + " already runs another graspsim simulation loop" +
         (other > 0 ? " (pid " + std::to_string(other) + ")" : std::string()) +
         ": the two hold each other off it and fall behind; give one another core (--cpu)";
}

int ChooseCore(int preferred, std::string* note, const std::string& dir, int cpus) {
  note->clear();
  if (cpus <= 0) cpus = static_cast<int>(std::min<long>(sysconf(_SC_NPROCESSORS_ONLN), CPU_SETSIZE));
  if (preferred < 0 || cpus < 2 || preferred >= cpus || !ClaimedElsewhere(preferred, dir)) return preferred;
  std::vector<int> free;
  for (int c = 0; c < cpus; ++c)
    if (c != preferred && !ClaimedElsewhere(c, dir)) free.push_back(c);
  const std::string held = ClaimCore(preferred, dir);  // who has it, in the words EnterRealtime would use
  if (held.empty()) return preferred;  // its loop ended meanwhile: the core is this process's now
  const std::string who = held.substr(0, held.find(':'));
  if (free.size() < 2) {
    // the last free core is left to the receiver, the renderer and the rest of the machine
    *note = who + (free.empty() ? ": every core runs one" : ": the one other free core is left to the "
                                                             "tracker's receiver and the rest of the machine") +
            "; this one shares core " + std::to_string(preferred) + " (--cpu N picks one)";
    return preferred;
  }
  for (int c : free) {
    if (!ClaimCore(c, dir).empty()) continue;  // taken meanwhile
    *note = who + ": this one runs on core " + std::to_string(c);
    return c;
  }
  return preferred;
}

PacingGrant LockMemory([[maybe_unused]] const PacingOptions& opt) {
  PacingGrant g;
#ifdef GRASPSIM_SANITIZED
  // a sanitizer's shadow memory is terabytes of reserved address space: not locked
  const bool lock = false;
#else
  const bool lock = opt.lock_memory && AsksRealtime(opt);
#endif
  if (!lock) return g;
  rlimit lim{};
  const bool unlimited = geteuid() == 0 || (getrlimit(RLIMIT_MEMLOCK, &lim) == 0 && lim.rlim_cur == RLIM_INFINITY);
  const int flags = unlimited ? (MCL_CURRENT | MCL_FUTURE) : MCL_CURRENT;
  if (mlockall(flags) == 0) {
    g.memory_locked = true;
  } else {
    const int e = errno;
    g.refused = std::string("mlockall refused (") + std::strerror(e) + "; needs CAP_IPC_LOCK or a memlock limit)";
  }
  return g;
}

PacingGrant EnterRealtime(const PacingOptions& opt, const PacingGrant* locked) {
  PacingGrant g;
  const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
  if (opt.cpu >= 0 && cpus > 1 && opt.cpu < cpus && opt.cpu < CPU_SETSIZE) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(opt.cpu, &set);
    const int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    if (rc == 0) {
      g.cpu = opt.cpu;
      g.refused = ClaimCore(opt.cpu);
    } else
      g.refused = "pinning to core " + std::to_string(opt.cpu) + " refused (" + std::strerror(rc) + ")";
  } else if (opt.cpu >= 0 && cpus > 1) {
    g.refused = "core " + std::to_string(opt.cpu) + " does not exist (" + std::to_string(cpus) +
                " online, 0 to " + std::to_string(cpus - 1) + "): not pinned";
  }
  if (opt.priority <= 0) return g;
  if (!AsksRealtime(opt)) {
    Append(&g.refused, "SCHED_FIFO not asked on a one-core machine");
    return g;
  }
  // 1 ns of timer slack: the wake-up is not deferred to batch it with others
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  sched_param sp{};
  sp.sched_priority = opt.priority;
  const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
  if (rc == 0) {
    g.fifo = true;
    g.priority = opt.priority;
  } else {
    Append(&g.refused, std::string("SCHED_FIFO ") + std::to_string(opt.priority) + " refused (" +
                           std::strerror(rc) + "; needs CAP_SYS_NICE or an rtprio limit, e.g. in "
                           "/etc/security/limits.conf)");
  }
  const PacingGrant mem = locked ? *locked : LockMemory(opt);
  g.memory_locked = mem.memory_locked;
  Append(&g.refused, mem.refused);
  return g;
}

void LeaveRealtime() {
  cpu_set_t all;
  CPU_ZERO(&all);
  const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
  for (int c = 0; c < cpus && c < CPU_SETSIZE; ++c) CPU_SET(c, &all);
  pthread_setaffinity_np(pthread_self(), sizeof all, &all);
  sched_param sp{};
  sp.sched_priority = 0;
  pthread_setschedparam(pthread_self(), SCHED_OTHER, &sp);
}

double StepSchedule::BudgetS(int64_t k, int64_t begin_ns, double fraction) const {
  const int64_t share = static_cast<int64_t>(std::llround(fraction * static_cast<double>(period_ns)));
  const int64_t end = std::min(begin_ns + share, DeadlineNs(k) - period_ns + share);
  return std::max(1e-9, 1e-9 * static_cast<double>(end - begin_ns));
}

int64_t StepSchedule::LatestBeginNs(int64_t k, double fraction) const {
  const double f = fraction > 0.0 && fraction < 1.0 ? fraction : 1.0;
  return DeadlineNs(k) - static_cast<int64_t>(std::llround(f * static_cast<double>(period_ns)));
}

double CarryContactsAfter(double step_budget, bool detect_every_step, double dt) {
  return step_budget > 0.0 && !detect_every_step ? step_budget * dt : 0.0;
}

int64_t MonotonicNs() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void WaitUntilNs(int64_t ns, int64_t spin_ns) {
  const int64_t sleep_to = ns - (spin_ns > 0 ? spin_ns : 0);
  if (MonotonicNs() < sleep_to) {
    timespec ts;
    ts.tv_sec = static_cast<time_t>(sleep_to / 1000000000);
    ts.tv_nsec = static_cast<long>(sleep_to % 1000000000);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
  }
  while (spin_ns > 0 && MonotonicNs() < ns) GS_SPIN_PAUSE();
}

}  // namespace gs::app
