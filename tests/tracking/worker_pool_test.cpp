// The step's threads (session/worker_pool.h): every task runs once, on the caller's
// thread or a worker's; a second caller runs its own tasks meanwhile; and the whole
// tracked hand stepped on two threads is the hand stepped on one, bit for bit
// (core/parallel.h). In the threads label: the tsan build runs them.
#include "session/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <memory>
#include <thread>
#include <vector>

#include "scene/paths.h"
#include "session/tracked_sim.h"

namespace gs::app {
namespace {

struct Tally {
  std::vector<std::atomic<int>> runs;
  std::atomic<int> bad_thread{0};
  std::atomic<int> on_workers{0};
  int threads = 0;
  explicit Tally(int n, int t) : runs(n), threads(t) {}
};

void Count(void* ctx, int task, int thread) {
  Tally& t = *static_cast<Tally*>(ctx);
  t.runs[task].fetch_add(1);
  if (thread < 0 || thread >= t.threads) t.bad_thread.fetch_add(1);
  if (thread > 0) t.on_workers.fetch_add(1);
}

TEST(WorkerPool, RunsEveryTaskOnceOnItsThreads) {
  WorkerPool pool(3);
  ASSERT_EQ(pool.threads(), 3);
  EXPECT_EQ(pool.started(), 0);  // no thread until tasks need one
  Tally single(1, 3);
  pool.Run(1, Count, &single);
  EXPECT_EQ(single.runs[0].load(), 1);
  EXPECT_EQ(pool.started(), 0);
  for (int round = 0; round < 300; ++round) {
    const int n = 1 + round % 40;
    Tally tally(n, 3);
    pool.Run(n, Count, &tally);
    for (int k = 0; k < n; ++k) ASSERT_EQ(tally.runs[k].load(), 1) << "round " << round << " task " << k;
    ASSERT_EQ(tally.bad_thread.load(), 0);
  }
  EXPECT_EQ(pool.started(), 2);
}

// a job the caller holds until a worker has taken one of its other tasks: done only
// if a worker joins (waited for by the state, not by a clock)
void RunNeedingAWorker(WorkerPool* pool) {
  struct Ctx {
    std::atomic<int> by_worker{0};
  } ctx;
  pool->Run(
      16,
      [](void* c, int task, int thread) {
        auto& x = *static_cast<Ctx*>(c);
        if (thread > 0) x.by_worker.fetch_add(1);
        if (task == 0)
          while (x.by_worker.load() == 0) std::this_thread::yield();
      },
      &ctx);
  EXPECT_GT(ctx.by_worker.load(), 0);
}

// the caller takes task 0 first and holds it until a worker has taken another:
// the workers do join in
TEST(WorkerPool, AWorkerTakesTasksWhileTheCallerWorks) {
  WorkerPool pool(2);
  RunNeedingAWorker(&pool);
}

// Jobs at a steady pace: the worker waits for the next on the clock, not asleep on
// the condition variable. A pause longer than it waits puts it to sleep there, and
// the next job still wakes it; a pool destroyed while its worker waits for a due job
// stops (a hang would end at the test's timeout).
TEST(WorkerPool, AWorkerWaitingForTheNextJobOnTheClockIsWokenWhenItComesLate) {
  for (int pause_ms : {0, 2, 20}) {
    auto pool = std::make_unique<WorkerPool>(2);
    for (int round = 0; round < 200; ++round) {
      Tally tally(8, 2);
      pool->Run(8, Count, &tally);
      for (int k = 0; k < 8; ++k) ASSERT_EQ(tally.runs[k].load(), 1);
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(pause_ms));
    RunNeedingAWorker(pool.get());
    RunNeedingAWorker(pool.get());
    pool.reset();
  }
}

// two worlds stepping on two threads share one pool: while one runs its tasks on
// it, the other runs its own on its own thread
TEST(WorkerPool, TwoCallersAtOnceEachRunTheirOwnTasks) {
  WorkerPool pool(2);
  std::atomic<int> failures{0};
  auto caller = [&] {
    for (int round = 0; round < 300; ++round) {
      Tally tally(17, 2);
      pool.Run(17, Count, &tally);
      for (int k = 0; k < 17; ++k) failures.fetch_add(tally.runs[k].load() != 1);
      failures.fetch_add(tally.bad_thread.load());
    }
  };
  std::thread a(caller), b(caller);
  a.join();
  b.join();
  EXPECT_EQ(failures.load(), 0);
}

// the shipped power grasp, its hand closing on the box and lifting it (1.0..1.5 s:
// every segment's pair with the box detected as a task), on two threads and on one
TEST(WorkerPool, TheWholeHandOnTwoThreadsIsTheHandOnOneBitForBit) {
  SyntheticDrive one, two;
  std::string error;
  const std::string scene = ResolveResource("config/whole_hand_power_grasp.yaml");
  ASSERT_TRUE(one.Load(scene, &error)) << error;
  ASSERT_TRUE(two.Load(scene, &error)) << error;
  two.sim().UseThreads(2);
  two.world().params.lanes_from_s = 0.0;  // every step on the lanes
  one.RunTo(1.0);
  two.RunTo(1.0);
  int steps_on_lanes = 0, most = 0;
  while (one.world().time < 1.5) {
    one.Step();
    two.Step();
    const World& a = one.world();
    const World& b = two.world();
    steps_on_lanes += b.profile.work.pairs_on_lanes > 1;
    most = std::max(most, b.profile.work.pairs_on_lanes);
    ASSERT_EQ(a.contacts.items.size(), b.contacts.items.size()) << "t = " << a.time;
    for (size_t k = 0; k < a.contacts.items.size(); ++k) {
      ASSERT_EQ(a.contacts.items[k].key, b.contacts.items[k].key) << "t = " << a.time;
      ASSERT_EQ(a.contacts.items[k].gap, b.contacts.items[k].gap) << "t = " << a.time;
    }
    for (size_t i = 0; i < a.bodies.size(); ++i) {
      ASSERT_EQ(a.bodies[i].pose.t, b.bodies[i].pose.t) << a.bodies[i].name << " at t = " << a.time;
      ASSERT_EQ(a.bodies[i].pose.R, b.bodies[i].pose.R) << a.bodies[i].name << " at t = " << a.time;
    }
  }
  EXPECT_GT(steps_on_lanes, 400);
  EXPECT_GE(most, 10);
  EXPECT_GT(one.world().contacts.items.size(), 10u);
}

}  // namespace
}  // namespace gs::app
