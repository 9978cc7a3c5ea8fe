#include "core/key_index.h"

#include <gtest/gtest.h>

#include <random>
#include <unordered_map>

#include "core/collision.h"

namespace gs {
namespace {

TEST(KeyIndex, FindsWhatWasInsertedForgetsOnClearAndRefusesBeyondItsRoom) {
  KeyIndex index;
  index.Reserve(1000);
  std::mt19937_64 rng(3);
  for (int round = 0; round < 3; ++round) {
    const int n = round == 0 ? 1000 : 40 + round;
    index.Clear(n);
    std::unordered_map<uint64_t, int> truth;
    // contact keys of a few bodies (neighbouring leaves: keys differing in low bits)
    while (static_cast<int>(truth.size()) < n) {
      const uint64_t key = ContactKey(static_cast<int>(rng() % 4), 4 + static_cast<int>(rng() % 3),
                                      static_cast<int>(rng() % 5000));
      if (truth.count(key)) continue;
      truth[key] = static_cast<int>(truth.size());
      ASSERT_TRUE(index.Insert(key, truth[key]));
    }
    EXPECT_EQ(index.size(), n);
    for (const auto& [key, value] : truth) ASSERT_EQ(index.Find(key), value);
    // a key inserted again keeps its first value; absent keys are not found
    index.Insert(truth.begin()->first, -7);
    EXPECT_EQ(index.Find(truth.begin()->first), truth.begin()->second);
    EXPECT_EQ(index.Find(ContactKey(9, 9, 1)), -1);
  }
  // the reserved count is the limit, whatever Clear was told
  index.Clear(10);
  int accepted = 0;
  for (int i = 0; i < 3000; ++i) accepted += index.Insert(ContactKey(1, 2, i), i);
  EXPECT_GE(accepted, 10);
  EXPECT_LE(accepted, 1000);
  for (int i = 0; i < accepted; ++i) ASSERT_EQ(index.Find(ContactKey(1, 2, i)), i);
  index.Clear(0);
  EXPECT_EQ(index.Find(ContactKey(1, 2, 0)), -1);
  EXPECT_EQ(index.size(), 0);
}

}  // namespace
}  // namespace gs
