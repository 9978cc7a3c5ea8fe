// A TaskRunner for the core tests (core/parallel.h): core starts no threads, so this
// one runs the tasks on the calling thread, in an order and on lanes of its own, and
// counts its runs. session/worker_pool.h is the threaded one.
#pragma once

#include "core/parallel.h"

namespace gs::test {

class ScriptedRunner final : public TaskRunner {
 public:
  /// `threads` lanes; the tasks first to last, or last to first when `reversed`;
  /// task k on lane k % threads
  ScriptedRunner(int threads, bool reversed) : threads_(threads), reversed_(reversed) {}
  int threads() const override { return threads_; }
  void Run(int count, void (*fn)(void*, int, int), void* ctx) override {
    ++runs;
    for (int k = 0; k < count; ++k) {
      const int t = reversed_ ? count - 1 - k : k;
      fn(ctx, t, t % threads_);
    }
  }
  int runs = 0;

 private:
  int threads_;
  bool reversed_;
};

}  // namespace gs::test
