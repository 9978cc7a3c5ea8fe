#include "session/worker_pool.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>

namespace gs::app {
namespace {

// the creating thread's cores less the one it is pinned to, when it is pinned to
// exactly one and others exist (else its cores as they are)
void LeaveTheCreatorsCore(const cpu_set_t& creator) {
  if (CPU_COUNT(&creator) != 1) return;
  cpu_set_t others;
  CPU_ZERO(&others);
  const long cores = sysconf(_SC_NPROCESSORS_ONLN);
  for (long c = 0; c < cores && c < CPU_SETSIZE; ++c)
    if (!CPU_ISSET(c, &creator)) CPU_SET(c, &others);
  if (CPU_COUNT(&others) > 0) pthread_setaffinity_np(pthread_self(), sizeof others, &others);  // best effort
}

// one turn of a busy wait: tells the core (and a hyperthread sharing it) that this
// thread only waits, so that the simulation thread beside it runs at full speed
inline void CpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

int WorkerPool::ThreadsFor(int given) {
  if (given > 0) return given;
  return std::thread::hardware_concurrency() >= 2 ? 2 : 1;
}

// the workers, from the thread that first runs tasks on them
void WorkerPool::Start() {
  cpu_set_t creator;
  CPU_ZERO(&creator);
  const bool known = pthread_getaffinity_np(pthread_self(), sizeof creator, &creator) == 0;
  workers_.reserve(static_cast<size_t>(threads_ - 1));
  for (int k = 1; k < threads_; ++k)
    workers_.emplace_back([this, k, creator, known] {
      if (known) LeaveTheCreatorsCore(creator);
      // its clock sleeps end on time (a normal thread's may end 50 us late)
      prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
      Work(k);
    });
}

WorkerPool::~WorkerPool() {
  stop_.store(true);
  Publish(generation_.load() + 1);
  for (std::thread& t : workers_) t.join();
}

void WorkerPool::Expect() {
  std::unique_lock<std::mutex> lock(busy_, std::try_to_lock);
  if (!lock.owns_lock() || workers_.empty()) return;
  {
    std::lock_guard<std::mutex> wake(wake_mutex_);
    expected_.fetch_add(1, std::memory_order_relaxed);
  }
  wake_.notify_all();
}

void WorkerPool::Publish(uint32_t generation) {
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    generation_.store(generation, std::memory_order_release);
  }
  wake_.notify_all();
}

void WorkerPool::Run(int count, void (*fn)(void*, int, int), void* ctx) {
  std::unique_lock<std::mutex> lock(busy_, std::try_to_lock);
  if (lock.owns_lock() && workers_.empty() && threads_ > 1 && count > 1) Start();
  if (!lock.owns_lock() || workers_.empty()) {
    for (int t = 0; t < count; ++t) fn(ctx, t, 0);
    return;
  }
  NoteJobStart();
  count_ = count;
  fn_ = fn;
  ctx_ = ctx;
  next_.store(0, std::memory_order_relaxed);
  const uint32_t g = generation_.load(std::memory_order_relaxed) + 1;
  state_.store((uint64_t{g} << 32) | kOpen, std::memory_order_release);
  Publish(g);
  Drain(0);
  // every task is taken: no worker joins any more; wait for those in it to finish theirs
  uint64_t s = state_.fetch_and(~kOpen, std::memory_order_acq_rel) & ~kOpen;
  while ((s & kJoinedMask) != 0) {
    std::this_thread::yield();
    s = state_.load(std::memory_order_acquire);
  }
}

// a worker enters the job of `generation` while it still takes workers
bool WorkerPool::Join(uint32_t generation) {
  uint64_t s = state_.load(std::memory_order_acquire);
  while ((s >> 32) == generation && (s & kOpen)) {
    if (state_.compare_exchange_weak(s, s + 1, std::memory_order_acq_rel)) return true;
  }
  return false;
}

void WorkerPool::Drain(int thread) {
  for (;;) {
    const int t = next_.fetch_add(1, std::memory_order_acq_rel);
    if (t >= count_) return;
    fn_(ctx_, t, thread);
  }
}

// the next job is due one interval (this start less the last) after this one
void WorkerPool::NoteJobStart() {
  const int64_t now = NowNs();
  const int64_t interval = now - last_start_ns_;
  const bool steady = last_start_ns_ > 0 && interval < std::chrono::nanoseconds(kDueWindow).count();
  due_ns_.store(steady ? now + interval : 0, std::memory_order_relaxed);
  last_start_ns_ = now;
}

// After a job: sleeps until shortly before the next is due, then waits awake for it
// until kExpectSpin past that. The sleep is on the condition variable, so that tasks
// coming early (or an Expect) wake it as before; tasks on time find it awake and
// wake nobody. True when they came (or the pool stops).
bool WorkerPool::AwaitDueJob(uint32_t seen, uint32_t expected) {
  const int64_t due = due_ns_.load(std::memory_order_relaxed);
  const int64_t now = NowNs();
  if (due <= now || due - now > std::chrono::nanoseconds(kDueWindow).count()) return false;
  const int64_t wake = due - std::chrono::nanoseconds(kDueLead).count();
  if (wake > now) {
    std::unique_lock<std::mutex> lock(wake_mutex_);
    wake_.wait_until(lock, std::chrono::steady_clock::time_point(std::chrono::nanoseconds(wake)), [&] {
      return generation_.load(std::memory_order_acquire) != seen ||
             expected_.load(std::memory_order_relaxed) != expected || stop_.load(std::memory_order_relaxed);
    });
  }
  const int64_t until = due + std::chrono::nanoseconds(kExpectSpin).count();
  while (generation_.load(std::memory_order_acquire) == seen && !stop_.load(std::memory_order_relaxed)) {
    if (NowNs() > until) return false;
    CpuRelax();
  }
  return true;
}

void WorkerPool::Work(int thread) {
  uint32_t seen = 0, expected = 0;
  bool due = false;  // a job just ended: wait for the next on the clock first
  for (;;) {
    if (due) {
      // an Expect meanwhile is for the job waited for here
      expected = expected_.load(std::memory_order_relaxed);
      due = AwaitDueJob(seen, expected);
    }
    if (!due) {
      std::unique_lock<std::mutex> lock(wake_mutex_);
      wake_.wait(lock, [&] {
        return generation_.load(std::memory_order_acquire) != seen || expected_.load(std::memory_order_relaxed) != expected;
      });
      expected = expected_.load(std::memory_order_relaxed);
    }
    // woken ahead of the tasks (Expect): awake until they come, for a while
    const auto until = std::chrono::steady_clock::now() + kExpectSpin;
    while (generation_.load(std::memory_order_acquire) == seen && !stop_.load(std::memory_order_relaxed) &&
           std::chrono::steady_clock::now() < until) {
      CpuRelax();
    }
    if (stop_.load()) return;
    const uint32_t g = generation_.load(std::memory_order_acquire);
    if (g == seen) continue;  // nothing came: asleep again
    seen = g;
    due = false;
    if (!Join(seen)) continue;
    Drain(thread);
    state_.fetch_sub(1, std::memory_order_acq_rel);
    due = true;
  }
}

}  // namespace gs::app
