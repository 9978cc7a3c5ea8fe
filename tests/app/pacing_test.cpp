// app/pacing.*: what the simulation loop asks of the OS is granted or said,
// never dropped in silence, and the wait ends at its deadline. Each case runs on
// a thread of its own so that the test process keeps normal scheduling.
#include "app/pacing.h"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include <thread>

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

}  // namespace
}  // namespace gs::app
