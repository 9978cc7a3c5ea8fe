// session/pacing.*: what the simulation loop asks of the OS is granted or said,
// never dropped in silence, and the wait ends at its deadline. Each case runs on
// a thread of its own so that the test process keeps normal scheduling.
#include "session/pacing.h"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <thread>
#include <vector>

namespace gs::app {
namespace {

struct Seen {
  PacingGrant grant;
  int policy = -1;
  int cpus_allowed = 0;
  bool on_cpu0_only = false;
};

Seen EnterOnAThread(const PacingOptions& opt) {
  Seen s;
  std::thread t([&] {
    s.grant = EnterRealtime(opt);
    sched_param sp{};
    pthread_getschedparam(pthread_self(), &s.policy, &sp);
    cpu_set_t set;
    CPU_ZERO(&set);
    pthread_getaffinity_np(pthread_self(), sizeof set, &set);
    s.cpus_allowed = CPU_COUNT(&set);
    s.on_cpu0_only = s.cpus_allowed == 1 && CPU_ISSET(0, &set);
    LeaveRealtime();
  });
  t.join();
  return s;
}

TEST(Pacing, NoPriorityKeepsNormalScheduling) {
  PacingOptions o;
  o.priority = 0;
  const Seen s = EnterOnAThread(o);
  EXPECT_FALSE(s.grant.fifo);
  EXPECT_EQ(s.policy, SCHED_OTHER);
  EXPECT_FALSE(s.grant.memory_locked);
  EXPECT_EQ(s.grant.Describe(), "normal scheduling");
  EXPECT_TRUE(s.grant.refused.empty()) << s.grant.refused;
}

TEST(Pacing, FifoIsGrantedOrTheRefusalSaysWhy) {
  // skipped only on a one-core machine, where pacing deliberately asks for no SCHED_FIFO
  if (sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "one core: SCHED_FIFO is not asked";
  PacingOptions o;
  o.priority = 10;
  o.lock_memory = false;
  const Seen s = EnterOnAThread(o);
  if (s.grant.fifo) {
    EXPECT_EQ(s.policy, SCHED_FIFO);
    EXPECT_EQ(s.grant.priority, 10);
    EXPECT_NE(s.grant.Describe().find("SCHED_FIFO 10"), std::string::npos);
  } else {
    EXPECT_EQ(s.policy, SCHED_OTHER);
    EXPECT_NE(s.grant.refused.find("SCHED_FIFO 10 refused"), std::string::npos) << s.grant.refused;
  }
}

TEST(Pacing, PinsToAnExistingCoreAndSaysSoOfOneThatIsNot) {
  // skipped only on a one-core machine: there is no other core to keep the renderer on
  if (sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "one core: nothing to pin to";
  PacingOptions o;
  o.cpu = 0;
  const Seen pinned = EnterOnAThread(o);
  EXPECT_EQ(pinned.grant.cpu, 0);
  EXPECT_TRUE(pinned.on_cpu0_only) << pinned.cpus_allowed << " cores allowed";
  EXPECT_NE(pinned.grant.Describe().find("core 0"), std::string::npos);

  o.cpu = 1023;
  const Seen none = EnterOnAThread(o);
  EXPECT_EQ(none.grant.cpu, -1);
  EXPECT_GT(none.cpus_allowed, 1);
  EXPECT_NE(none.grant.refused.find("core 1023 does not exist"), std::string::npos) << none.grant.refused;
}

// Two simulation loops pinned to one core hold each other off it: the second process to
// claim a core hears which process has it; a claim dies with its process.
TEST(Pacing, ASecondProcessOnAClaimedCoreIsToldWhoHasIt) {
  char dir_template[] = "/tmp/graspsim_claim_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  int claimed[2], release[2];
  ASSERT_EQ(pipe(claimed), 0);
  ASSERT_EQ(pipe(release), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const bool ok = ClaimCore(3, dir).empty();
    char c = ok ? 'y' : 'n';
    (void)!write(claimed[1], &c, 1);
    (void)!read(release[0], &c, 1);  // holds the claim until the parent is done
    _exit(0);
  }
  char c = 0;
  ASSERT_EQ(read(claimed[0], &c, 1), 1);
  EXPECT_EQ(c, 'y') << "the first claim of a free core succeeds";
  const std::string told = ClaimCore(3, dir);
  EXPECT_NE(told.find("core 3 already runs another graspsim simulation loop (pid " + std::to_string(child) + ")"),
            std::string::npos)
      << told;
  EXPECT_TRUE(ClaimCore(4, dir).empty()) << "another core is free";
  EXPECT_TRUE(ClaimCore(4, dir).empty()) << "a core this process holds stays its own";
  (void)!write(release[1], &c, 1);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(ClaimCore(3, dir).empty()) << "the claim ended with its process";
  for (int fd : {claimed[0], claimed[1], release[0], release[1]}) close(fd);
  for (int core : {3, 4}) std::remove((dir + "/graspsim-core-" + std::to_string(core) + ".lock").c_str());
  rmdir(dir.c_str());
}

// A child process holds the claims on `cores` until told to go (a loop running elsewhere).
class ClaimHolder {
 public:
  ClaimHolder(const std::vector<int>& cores, const std::string& dir) {
    if (pipe(claimed_) != 0 || pipe(release_) != 0) return;
    pid_ = fork();
    if (pid_ == 0) {
      bool ok = true;
      for (int c : cores) ok = ClaimCore(c, dir).empty() && ok;
      char x = ok ? 'y' : 'n';
      (void)!write(claimed_[1], &x, 1);
      (void)!read(release_[0], &x, 1);
      _exit(0);
    }
    char x = 0;
    ok_ = pid_ > 0 && read(claimed_[0], &x, 1) == 1 && x == 'y';
  }
  ~ClaimHolder() {
    char x = 0;
    (void)!write(release_[1], &x, 1);
    if (pid_ > 0) waitpid(pid_, nullptr, 0);
    for (int fd : {claimed_[0], claimed_[1], release_[0], release_[1]}) close(fd);
  }
  bool ok() const { return ok_; }
  pid_t pid() const { return pid_; }

 private:
  int claimed_[2] = {-1, -1}, release_[2] = {-1, -1};
  pid_t pid_ = -1;
  bool ok_ = false;
};

// no process holds the claim file of `core` in `dir` (a lock taken and let go at once)
bool LockFileFree(const std::string& dir, int core) {
  const int fd = open((dir + "/graspsim-core-" + std::to_string(core) + ".lock").c_str(), O_RDONLY);
  if (fd < 0) return true;
  const bool free = flock(fd, LOCK_EX | LOCK_NB) == 0;
  close(fd);
  return free;
}

// without --cpu, a loop whose core another graspsim loop holds goes to a free one and says so,
// as long as a core stays free for normal threads; else it stays where it was asked and says why.
// The claims live in a directory of the test's own, and the core counts are given, so that the
// case runs the same on any machine.
TEST(Pacing, AnUnnamedCoreThatIsTakenMovesToAFreeOneWhileAnotherStaysFree) {
  char dir_template[] = "/tmp/graspsim_choose_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  std::string note = "stale";
  EXPECT_EQ(ChooseCore(0, &note, dir, 4), 0) << "a free core stays the one asked for";
  EXPECT_EQ(note, "");
  note = "stale";
  EXPECT_EQ(ChooseCore(-1, &note, dir, 4), -1) << "no pinning asked, none chosen";
  EXPECT_EQ(note, "");
  {
    ClaimHolder other({1}, dir);
    ASSERT_TRUE(other.ok());
    const std::string who = "core 1 already runs another graspsim simulation loop (pid " + std::to_string(other.pid()) + ")";
    // two cores: the other one is the only free core, left to the receiver and the rest
    EXPECT_EQ(ChooseCore(1, &note, dir, 2), 1);
    EXPECT_EQ(note, who + ": the one other free core is left to the tracker's receiver and the rest of the machine; "
                          "this one shares core 1 (--cpu N picks one)");
    EXPECT_TRUE(LockFileFree(dir, 0)) << "nothing was claimed for a move that did not happen";
    // four cores: three free; the lowest is taken and claimed
    EXPECT_EQ(ChooseCore(1, &note, dir, 4), 0);
    EXPECT_EQ(note, who + ": this one runs on core 0");
    EXPECT_TRUE(ClaimCore(0, dir).empty()) << "the core it moved to is this process's now";
  }
  {
    // three cores, two held by others, the third this process's own: nowhere to go
    ClaimHolder others({1, 2}, dir);
    ASSERT_TRUE(others.ok());
    EXPECT_EQ(ChooseCore(2, &note, dir, 3), 2);
    EXPECT_NE(note.find(": the one other free core is left to"), std::string::npos) << note;
  }
  {
    // every core held by another loop (claims in a directory this process never claimed in)
    char other_template[] = "/tmp/graspsim_choose_XXXXXX";
    ASSERT_NE(mkdtemp(other_template), nullptr);
    const std::string other_dir = other_template;
    {
      ClaimHolder all({0, 1, 2}, other_dir);
      ASSERT_TRUE(all.ok());
      EXPECT_EQ(ChooseCore(1, &note, other_dir, 3), 1);
      EXPECT_NE(note.find("(pid " + std::to_string(all.pid()) + "): every core runs one; this one shares core 1"),
                std::string::npos)
          << note;
    }
    for (int c = 0; c < 3; ++c) std::remove((other_dir + "/graspsim-core-" + std::to_string(c) + ".lock").c_str());
    rmdir(other_dir.c_str());
  }
  note = "stale";
  EXPECT_EQ(ChooseCore(1, &note, dir, 4), 1) << "the claim ended with its process";
  EXPECT_EQ(note, "");
  for (int c = 0; c < 4; ++c) std::remove((dir + "/graspsim-core-" + std::to_string(c) + ".lock").c_str());
  rmdir(dir.c_str());
}

TEST(Pacing, WaitEndsAtItsDeadlineAndReturnsAtOnceWhenItHasPassed) {
  for (int64_t spin : {int64_t{0}, int64_t{200000}}) {
    const int64_t deadline = MonotonicNs() + 2000000;  // 2 ms
    WaitUntilNs(deadline, spin);
    EXPECT_GE(MonotonicNs(), deadline) << "spin " << spin;
  }
  const int64_t before = MonotonicNs();
  WaitUntilNs(before - 1000000000, 0);  // a second ago
  // no sleep: far less than a second (a generous bound, not a timing figure)
  EXPECT_LT(MonotonicNs() - before, 500000000);
}

// The schedule's arithmetic: deadlines do not move with the lead, only the release;
// a step's budget counts from its beginning and never reaches past the same point of
// its slot; a long step after short ones misses its deadline without a lead and meets
// it with one, and steps that run long one after the other use the lead up.
TEST(Pacing, ALeadLetsALongStepUseWhatTheStepsBeforeItLeft) {
  const int64_t ms = 1000000;
  StepSchedule strict;
  strict.start_ns = 10 * ms;
  strict.period_ns = ms;
  StepSchedule led = strict;
  led.lead = 1;
  for (int64_t k : {int64_t{0}, int64_t{7}}) {
    EXPECT_EQ(strict.DeadlineNs(k), led.DeadlineNs(k));
    EXPECT_EQ(strict.ReleaseNs(k), 10 * ms + k * ms);
    EXPECT_EQ(led.ReleaseNs(k), strict.ReleaseNs(k) - ms);
  }
  // budget 0.8: a step begun on time has 0.8 ms; 0.3 ms late, 0.5 ms; begun a slot
  // early (the lead), still 0.8 ms, not 1.8; past its budget's end, 1 ns (one sweep)
  EXPECT_NEAR(strict.BudgetS(3, strict.ReleaseNs(3), 0.8), 0.8e-3, 1e-12);
  EXPECT_NEAR(strict.BudgetS(3, strict.ReleaseNs(3) + ms * 3 / 10, 0.8), 0.5e-3, 1e-12);
  EXPECT_NEAR(led.BudgetS(3, led.ReleaseNs(3), 0.8), 0.8e-3, 1e-12);
  EXPECT_NEAR(led.BudgetS(3, led.ReleaseNs(3) + ms * 13 / 10, 0.8), 0.5e-3, 1e-12);
  EXPECT_EQ(strict.BudgetS(3, strict.DeadlineNs(3), 0.8), 1e-9);
  // woke late: too late to hold the whole budget (0.2 ms of slack in the slot, plus the lead)
  EXPECT_EQ(strict.LatestBeginNs(3, 0.8), strict.ReleaseNs(3) + ms / 5);
  EXPECT_EQ(led.LatestBeginNs(3, 0.8), led.ReleaseNs(3) + ms + ms / 5);
  EXPECT_EQ(strict.LatestBeginNs(3, 0.0), strict.ReleaseNs(3));  // no budget: any late start
  // step times in ms: short, one of 1.5 ms, short again, then three of 1.2 ms in a row
  const std::vector<double> work = {0.3, 0.3, 1.5, 0.3, 0.3, 0.3, 1.2, 1.2, 1.2, 0.3, 0.3, 0.3, 0.3, 0.3};
  const auto missed = [&](const StepSchedule& s, std::vector<int64_t>* which) {
    int64_t end = 0;
    for (size_t k = 0; k < work.size(); ++k) {
      const int64_t begin = std::max(end, s.ReleaseNs(static_cast<int64_t>(k)));
      end = begin + static_cast<int64_t>(work[k] * static_cast<double>(ms));
      if (end > s.DeadlineNs(static_cast<int64_t>(k))) which->push_back(static_cast<int64_t>(k));
    }
  };
  std::vector<int64_t> strict_missed, led_missed;
  missed(strict, &strict_missed);
  missed(led, &led_missed);
  EXPECT_EQ(strict_missed, (std::vector<int64_t>{2, 6, 7, 8})) << "each long step misses its own deadline";
  // with the lead: the 1.5 ms step ends 0.5 ms before its deadline; each 1.2 ms step
  // begins 0.2 ms further past its release than the one before (0.2, 0.4, 0.6 ms of the
  // one-timestep lead used up): all on time
  EXPECT_TRUE(led_missed.empty()) << led_missed.size() << " missed, the first " << led_missed.front();
}

}  // namespace
}  // namespace gs::app
