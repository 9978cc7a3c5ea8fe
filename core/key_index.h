// A fixed-capacity hash index from 64-bit contact keys to small integers, for
// finding last step's row or force of a contact in O(1): open addressing with
// linear probing, cleared in O(1) by a generation stamp. Reserve() sizes it once;
// Insert() never allocates and refuses (returns false) beyond the reserved count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace gs {

class KeyIndex {
 public:
  /// Room for `n` keys (the table is kept at most half full).
  void Reserve(int n) {
    int bits = 4;
    while ((1 << bits) < 2 * n) ++bits;
    if (static_cast<int>(slots_.size()) >= (1 << bits)) return;
    shift_ = 64 - bits;
    mask_ = (static_cast<size_t>(1) << bits) - 1;
    slots_.assign(static_cast<size_t>(1) << bits, Slot{});
    max_count_ = n;
    count_ = 0;
  }
  /// Empties the index; `expected` keys (at most the reserved count) set the part of
  /// the table used until the next Clear, so that a small step probes a small table.
  void Clear(int expected) {
    int bits = 4;
    while ((1 << bits) < 2 * expected && (static_cast<size_t>(1) << bits) < slots_.size()) ++bits;
    shift_ = 64 - bits;
    mask_ = (static_cast<size_t>(1) << bits) - 1;
    count_ = 0;
    if (++stamp_ == 0) {  // the stamp wrapped: forget every slot for real
      for (Slot& s : slots_) s.stamp = 0;
      stamp_ = 1;
    }
  }
  /// Adds key -> value (a key already present keeps its first value); false when
  /// the reserved count, or half the part in use, is reached (the key is not added).
  bool Insert(uint64_t key, int value) {
    // at most half of the part in use is filled, so that a probe always ends
    if (count_ >= max_count_ || static_cast<size_t>(count_) >= (mask_ + 1) / 2) return false;
    for (size_t i = Home(key);; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (s.stamp != stamp_) {
        s = Slot{key, value, stamp_};
        ++count_;
        return true;
      }
      if (s.key == key) return true;
    }
  }
  /// The value of `key`, or -1.
  int Find(uint64_t key) const {
    if (slots_.empty()) return -1;
    for (size_t i = Home(key);; i = (i + 1) & mask_) {
      const Slot& s = slots_[i];
      if (s.stamp != stamp_) return -1;
      if (s.key == key) return s.value;
    }
  }
  int size() const { return count_; }

 private:
  struct Slot {
    uint64_t key = 0;
    int value = -1;
    uint32_t stamp = 0;
  };
  size_t Home(uint64_t key) const { return static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_); }
  std::vector<Slot> slots_;
  int shift_ = 60;
  size_t mask_ = 15;
  int count_ = 0;
  int max_count_ = 0;
  uint32_t stamp_ = 1;
};

}  // namespace gs
