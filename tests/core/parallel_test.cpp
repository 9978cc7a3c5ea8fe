// The step's tasks on a runner's threads (core/parallel.h, World::UseRunner): the
// body pairs detected in any order, on any thread, give the contacts and the motion
// of the step detecting them one after the other in one thread, bit for bit. core
// starts no threads, so the runner here runs the tasks in an order of its own on
// three lanes (tests/core/task_runners.h); tests/tracking/worker_pool_test.cpp runs a world on real threads.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "core/parallel.h"
#include "core/world.h"
#include "soft_bodies.h"
#include "task_runners.h"

namespace gs {
namespace {

// four soft balls dropped in a heap on the soft slab: ball-slab and ball-ball pairs
void Heap(World& w) {
  ASSERT_GE(AddBody(w, test::SoftSlab("slab")), 0);
  const Vec3 at[4] = {{-0.006, 0.0, 0.0205}, {0.006, 0.0, 0.0205}, {0.0, 0.009, 0.022}, {0.0, -0.004, 0.038}};
  for (const Vec3& p : at) ASSERT_GE(AddBody(w, test::SoftBall(p)), 0);
  w.Finalize();
}

TEST(Parallel, PairsDetectedOutOfOrderOnLanesGiveTheSameStepBitForBit) {
  World alone, shared;
  Heap(alone);
  Heap(shared);
  test::ScriptedRunner runner(3, true);  // last to first, on three lanes
  shared.params.lanes_from_s = 0.0;  // every step on the lanes
  shared.UseRunner(&runner);
  ASSERT_EQ(shared.lanes.size(), 3u);
  int on_lanes = 0, most_pairs = 0;
  for (int k = 0; k < 250; ++k) {
    alone.Step();
    shared.Step();
    on_lanes += shared.profile.work.pairs_on_lanes;
    most_pairs = std::max(most_pairs, shared.profile.work.pairs_on_lanes);
    EXPECT_EQ(alone.profile.work.pairs_on_lanes, 0);
    ASSERT_EQ(alone.contacts.items.size(), shared.contacts.items.size()) << "step " << k;
    for (size_t c = 0; c < alone.contacts.items.size(); ++c) {
      const Contact& x = alone.contacts.items[c];
      const Contact& y = shared.contacts.items[c];
      ASSERT_EQ(x.key, y.key) << "step " << k;
      ASSERT_EQ(x.gap, y.gap) << "step " << k;
      ASSERT_EQ(x.normal, y.normal) << "step " << k;
      ASSERT_EQ(x.anchor[1], y.anchor[1]) << "step " << k;
    }
    ASSERT_EQ(alone.profile.collision.contacts, shared.profile.collision.contacts) << "step " << k;
    ASSERT_EQ(alone.profile.collision.projections, shared.profile.collision.projections) << "step " << k;
    for (size_t b = 0; b < alone.bodies.size(); ++b) {
      ASSERT_EQ(alone.bodies[b].pose.t, shared.bodies[b].pose.t) << "step " << k << " body " << b;
      ASSERT_EQ(alone.bodies[b].pose.R, shared.bodies[b].pose.R) << "step " << k << " body " << b;
      ASSERT_EQ(0, std::memcmp(alone.bodies[b].u.data(), shared.bodies[b].u.data(),
                               alone.bodies[b].u.size() * sizeof(Vec3)));
    }
  }
  // the heap settles with balls on the slab and on each other: several pairs a step
  EXPECT_GE(most_pairs, 4);
  EXPECT_GT(on_lanes, 250);
  EXPECT_GT(runner.runs, 100);
  EXPECT_GT(alone.contacts.items.size(), 20u);
}

// below WorldParams::lanes_from_s the pairs stay on the calling thread
TEST(Parallel, LightStepsStayOnTheCallingThread) {
  World w;
  Heap(w);
  test::ScriptedRunner runner(3, true);  // last to first, on three lanes
  w.params.lanes_from_s = 1e9;
  w.UseRunner(&runner);
  for (int k = 0; k < 20; ++k) {
    w.Step();
    EXPECT_EQ(w.profile.work.pairs_on_lanes, 0);
  }
  EXPECT_EQ(runner.runs, 0);
  // no runner: no lanes kept
  w.UseRunner(nullptr);
  EXPECT_TRUE(w.lanes.empty());
}

}  // namespace
}  // namespace gs
