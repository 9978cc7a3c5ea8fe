// Tasks of a step that may run on several threads. core starts no threads: an
// application that has them gives the world a TaskRunner (World::UseRunner, a pool in
// session/worker_pool.h); without one every task runs on the calling thread, in
// order. A task writes only its own outputs and the outputs are gathered in task
// order, so a step's results do not depend on which thread ran what, or when.
#pragma once

namespace gs {

class TaskRunner {
 public:
  virtual ~TaskRunner() = default;
  /// the threads tasks may run on, the caller's included (at least 1)
  virtual int threads() const = 0;
  /// Calls fn(ctx, task, thread) once for every task in [0, count), each on one of the
  /// threads (thread in [0, threads()); the caller's is 0), and returns when all have
  /// returned. Tasks are taken in index order. Allocates nothing.
  virtual void Run(int count, void (*fn)(void* ctx, int task, int thread), void* ctx) = 0;
  /// Tasks will come within a fraction of a millisecond: a runner whose threads sleep
  /// may wake them now, so that they are ready when Run comes (a hint; may do nothing).
  virtual void Expect() {}
};

/// body(task, thread) for every task in [0, count): on the runner's threads, or here
/// in order (thread 0) without a runner or with fewer than two tasks.
template <class F>
void RunTasks(TaskRunner* runner, int count, F& body) {
  if (!runner || runner->threads() < 2 || count < 2) {
    for (int t = 0; t < count; ++t) body(t, 0);
    return;
  }
  runner->Run(count, [](void* ctx, int task, int thread) { (*static_cast<F*>(ctx))(task, thread); }, &body);
}

}  // namespace gs
