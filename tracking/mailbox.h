// A lock-free latest-value mailbox between one writer thread and one reader
// thread (a triple buffer): the writer never waits and never blocks the reader;
// the reader always gets the newest complete value; older values are dropped,
// as the DTrack SDK drops stale datagrams. T must be copyable without allocating
// for the hand-off to be allocation-free (a fixed-size struct).
#pragma once

#include <atomic>
#include <cstdint>

namespace gs::tracking {

template <class T>
class LatestMailbox {
 public:
  /// Writer: publishes a copy of `value`.
  void Write(const T& value) {
    buffers_[back_] = value;
    // hand the back buffer over as the newest; take whatever was there as the new back
    const uint8_t old = middle_.exchange(static_cast<uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = old & kIndex;
    writes_.fetch_add(1, std::memory_order_relaxed);
  }

  /// Reader: copies the newest value into *out when there is one not read yet.
  bool Read(T* out) {
    if (!(middle_.load(std::memory_order_relaxed) & kFresh)) return false;
    const uint8_t old = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = old & kIndex;
    *out = buffers_[front_];
    return true;
  }

  /// Sets every buffer to `value` (e.g. to give vectors their capacity) and
  /// marks nothing fresh. Only before the threads start.
  void Fill(const T& value) {
    for (T& b : buffers_) b = value;
    middle_.store(1);
    back_ = 0;
    front_ = 2;
  }

  /// Values written so far (reader - writes - reads = values dropped as stale).
  uint64_t writes() const { return writes_.load(std::memory_order_relaxed); }

 private:
  static constexpr uint8_t kFresh = 0x4, kIndex = 0x3;
  T buffers_[3];
  std::atomic<uint8_t> middle_{1};
  uint8_t back_ = 0;   // writer's
  uint8_t front_ = 2;  // reader's
  std::atomic<uint64_t> writes_{0};
};

}  // namespace gs::tracking
