// A pool of threads that runs a step's tasks (core/parallel.h) next to the thread
// that steps the world: World::UseRunner(&pool). The calling thread takes tasks too;
// a worker asleep when the tasks come wakes and joins in late, never
// holding up the step: the tasks are taken one at a time, in index order, by
// whoever is free. While the pool runs one caller's tasks another caller (a second
// world stepping on another thread) runs its own on its own thread.
//
// The workers start with the first tasks that need them (a scene whose steps stay
// light never starts one) and inherit the scheduling of the thread that brought
// them in (SCHED_FIFO in a real-time loop) but not its core: a thread pinned to one
// core puts them on the others.
//
// Steps come at a steady pace (1 kHz live, back to back offline), and so do their
// tasks. A worker done with one job sleeps until shortly before the next is due (the
// last job's start plus the interval between the last two), then waits awake for
// it: the caller's Expect and Run then find no sleeper to wake. Waking a sleeping
// thread is a futex syscall on the caller's thread, 0.04 ms on a virtual machine, a
// tenth of the whole hand's step at the paper's densities. Tasks (or an Expect) that
// come before the worker is up wake it as before; tasks that do not come within
// kExpectSpin of their due time leave it asleep until the next.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "core/parallel.h"

namespace gs::app {

class WorkerPool final : public TaskRunner {
 public:
  /// `threads` in all, the caller's included: threads - 1 workers (none below 2)
  explicit WorkerPool(int threads) : threads_(std::max(1, threads)) {}
  ~WorkerPool() override;
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int threads() const override { return threads_; }
  /// the workers started so far (0 until a Run needed them)
  int started() const { return static_cast<int>(workers_.size()); }
  void Run(int count, void (*fn)(void* ctx, int task, int thread), void* ctx) override;
  /// Wakes the started workers to wait for the coming tasks awake, spinning for at
  /// most kExpectSpin before they sleep again: the tasks then do not wait for a wake-up.
  void Expect() override;

  /// the threads asked for (`given` > 0), or else 2 on a machine of 2 cores or more, 1 on one
  static int ThreadsFor(int given);

 private:
  // state_: the job's generation (high 32 bits), whether it takes workers (bit 31)
  // and how many workers are in it (low 31 bits)
  static constexpr uint64_t kOpen = uint64_t{1} << 31;
  static constexpr std::chrono::microseconds kExpectSpin{300};
  /// how long before a job is due a worker wakes to wait for it awake
  static constexpr std::chrono::microseconds kDueLead{200};
  /// jobs further apart than this are not waited for on the clock
  static constexpr std::chrono::milliseconds kDueWindow{5};
  static constexpr uint64_t kJoinedMask = kOpen - 1;
  void Start();
  void Work(int thread);
  void Publish(uint32_t generation);
  bool Join(uint32_t generation);
  void Drain(int thread);
  void NoteJobStart();
  bool AwaitDueJob(uint32_t seen, uint32_t expected);

  int threads_ = 1;
  std::vector<std::thread> workers_;
  std::mutex busy_;                    // one caller's tasks at a time
  std::mutex wake_mutex_;              // guards generation_'s changes, for wake_
  std::condition_variable wake_;       // workers sleep on it until generation_ changes
  std::atomic<uint32_t> generation_{0};
  std::atomic<uint32_t> expected_{0};  // bumped by Expect
  std::atomic<uint64_t> state_{0};
  std::atomic<int> next_{0};           // the next task to take
  int count_ = 0;
  void (*fn_)(void*, int, int) = nullptr;
  void* ctx_ = nullptr;
  std::atomic<bool> stop_{false};
  // the steady clock (ns) at which the next job is due, 0 when unknown; the last
  // job's start (the caller's, under busy_)
  std::atomic<int64_t> due_ns_{0};
  int64_t last_start_ns_ = 0;
};

}  // namespace gs::app
