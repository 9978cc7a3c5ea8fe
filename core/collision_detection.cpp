// Collision detection stage: refit the deformed bodies' trees, then a broad
// phase on root spheres and the paper's two-tree traversal with MLS projection
// for every pair that may touch (collision.h). Pairs of bodies that cannot move
// (fixed or kinematic against fixed or kinematic) are not tested, nor pairs of
// sleeping bodies (sleep.cpp). With a runner (World::UseRunner) the pairs are
// detected on its threads, each into its thread's lane, and their contacts gathered
// in the pair loop's order: the same contacts as in one thread, bit for bit.
#include <algorithm>
#include <chrono>

#include "core/world.h"

namespace gs {
namespace {

// refits only the trees whose control points moved
void RefitTrees(World& w) {
  for (Body& b : w.bodies) {
    if (!b.deform.enabled() || b.geometry.is_plane) continue;
    bool any = false;
    for (uint8_t c : b.u_changed) any |= (c != 0);
    if (!any) continue;
    RefitStats rs;
    b.geometry.tree.Refit(b.u.data(), b.u_spread.data(), b.u_changed.data(), w.params.refit_stop_level, &rs);
    ++w.profile.work.refit_trees;
    w.profile.work.refit_nodes += rs.nodes_visited;
    std::fill(b.u_changed.begin(), b.u_changed.end(), 0);
  }
}

PairCache* CacheOf(World& w, int i, int j) {
  const size_t n = w.bodies.size();
  return w.pair_caches.empty() ? nullptr : &w.pair_caches[static_cast<size_t>(i) * n + j];
}

// what becomes of a body pair in the step's collision detection
enum class EPair { Detect, Asleep, Carried };

// keeps the pair's last contacts, moved with the bodies (asleep or carried)
bool Kept(EPair e) { return e != EPair::Detect; }

// Calls visit(i, j, what) for every body pair to detect this step, in the pair
// loop's order (i, then j > i): asleep (its last contacts reused, sleep.cpp),
// carried in a step short of time (its last contacts reused, carried_contacts.cpp)
// or detected, whose root spheres overlap and which its last detection did not
// prove apart by more than the motion since (PairStaysClear: no contact, not visited).
template <class Visit>
void ForEachPairToDetect(World& w, Visit&& visit) {
  const int n = static_cast<int>(w.bodies.size());
  for (int i = 0; i < n; ++i) {
    const Body& a = w.bodies[i];
    const CollisionShape sa = a.Shape();
    for (int j = i + 1; j < n; ++j) {
      const Body& b = w.bodies[j];
      if (a.articulation < 0 && b.articulation < 0) continue;
      // two fingertips of one finger, segments of one tracked finger (World::CanTouch)
      if (!w.CanTouch(i, j)) continue;
      ++w.profile.work.body_pairs;
      if (PairAsleep(w, i, j)) {
        visit(i, j, EPair::Asleep);
        continue;
      }
      ++w.profile.work.pair_tests;
      if (!RootsOverlap(sa, a.pose, b.Shape(), b.pose, w.params.collision.contact_threshold)) continue;
      if (w.carrying_ && PairCarried(w, i, j)) {
        visit(i, j, EPair::Carried);
        continue;
      }
      // proven apart by more than the bodies moved since its last detection: no contact
      const PairCache* cache = CacheOf(w, i, j);
      const double thr = w.params.collision.contact_threshold;
      if (w.params.collision.skip_clear_pairs && cache && PairStaysClear(sa, a.pose, b.Shape(), b.pose, *cache, thr)) {
        ++w.profile.work.pairs_clear;
        continue;
      }
      ++w.profile.work.pairs_traversed;
      visit(i, j, EPair::Detect);
    }
  }
}

// refits the trees once a step: at its start, or in a step that may carry contacts
// before the first pair that is detected (when every pair carries, the moved
// control points stay marked for the next refit)
void RefitOnce(World& w, bool* done) {
  if (*done) return;
  *done = true;
  const auto t0 = std::chrono::steady_clock::now();
  RefitTrees(w);
  w.profile.refit = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// every pair on the calling thread, straight into the world's contacts
void DetectInOrder(World& w, bool* refit) {
  ForEachPairToDetect(w, [&](int i, int j, EPair what) {
    if (Kept(what)) {
      ReuseContacts(w, i, j, what == EPair::Carried);
      return;
    }
    RefitOnce(w, refit);
    const Body& a = w.bodies[i];
    const Body& b = w.bodies[j];
    CollidePair(i, a.Shape(), a.pose, j, b.Shape(), b.pose, w.params.collision, &w.collision_scratch, &w.contacts,
                &w.profile.collision, CacheOf(w, i, j));
  });
}

// the pairs listed, collided on the runner's threads into their lanes (the larger
// first: the served leaf-pair list's length as the measure), then gathered in order
void DetectOnLanes(World& w, bool* refit) {
  w.pair_tasks.clear();
  w.task_order.clear();
  ForEachPairToDetect(w, [&](int i, int j, EPair what) {
    if (!Kept(what)) w.task_order.push_back(static_cast<int>(w.pair_tasks.size()));
    World::PairTask t;
    t.i = i;
    t.j = j;
    t.kept = Kept(what);
    t.carried = what == EPair::Carried;
    w.pair_tasks.push_back(t);
  });
  if (!w.task_order.empty()) RefitOnce(w, refit);
  auto size = [&](int t) {
    const PairCache* c = CacheOf(w, w.pair_tasks[t].i, w.pair_tasks[t].j);
    return c ? c->pairs.size() : size_t{0};
  };
  // (std::sort with the index breaking ties: the same order every time, and unlike
  // std::stable_sort no scratch buffer)
  std::sort(w.task_order.begin(), w.task_order.end(),
            [&](int x, int y) { return size(x) != size(y) ? size(x) > size(y) : x < y; });
  for (World::CollisionLane& lane : w.lanes) {
    lane.contacts.Clear();
    lane.stats = CollisionStats{};
  }
  auto collide = [&w](int k, int thread) {
    World::PairTask& t = w.pair_tasks[w.task_order[k]];
    World::CollisionLane& lane = w.lanes[thread];
    const Body& a = w.bodies[t.i];
    const Body& b = w.bodies[t.j];
    t.lane = thread;
    t.begin = static_cast<int>(lane.contacts.items.size());
    CollidePair(t.i, a.Shape(), a.pose, t.j, b.Shape(), b.pose, w.params.collision, &lane.scratch, &lane.contacts,
                &lane.stats, CacheOf(w, t.i, t.j));
    t.end = static_cast<int>(lane.contacts.items.size());
  };
  RunTasks(w.runner(), static_cast<int>(w.task_order.size()), collide);
  w.profile.work.pairs_on_lanes = static_cast<int>(w.task_order.size());
  // gathered in the pair loop's order; the contacts kept and dropped are the ones
  // the world's buffer keeps and drops, as in one thread
  CollisionStats& total = w.profile.collision;
  for (const World::CollisionLane& lane : w.lanes) total.Add(lane.stats);
  int kept = 0, dropped = 0;
  for (const World::PairTask& t : w.pair_tasks) {
    if (t.kept) {
      ReuseContacts(w, t.i, t.j, t.carried);
      continue;
    }
    const std::vector<Contact>& items = w.lanes[t.lane].contacts.items;
    for (int k = t.begin; k < t.end; ++k) (w.contacts.Push(items[k]) ? kept : dropped) += 1;
  }
  int lane_contacts = 0;
  for (const World::CollisionLane& lane : w.lanes) lane_contacts += lane.stats.contacts;
  total.contacts += kept - lane_contacts;
  total.dropped += dropped;
}

}  // namespace

void DetectCollisions(World& w) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  bool refit = false;
  if (!w.carrying_) RefitOnce(w, &refit);
  // on the runner's threads when the last steps' pairs took long enough to pay for
  // waking them (WorldParams::lanes_from_s; the results are the same either way)
  w.contacts.Clear();
  if (w.runner() && w.runner()->threads() > 1 && w.lanes.size() >= static_cast<size_t>(w.runner()->threads()) &&
      w.last_pairs_s_ >= w.params.lanes_from_s)
    DetectOnLanes(w, &refit);
  else
    DetectInOrder(w, &refit);
  // the median of the last nine steps: neither a lone heavy step (a cache built) nor a
  // step the system preempted (its wall time on a busy machine) moves pairs onto the lanes
  // (a step that carried its pairs' contacts says nothing of what detecting them takes)
  w.profile.contacts_carried = w.profile.work.pairs_carried > 0;
  if (!w.profile.contacts_carried) {
    w.pair_samples_[w.pair_sample_next_] = w.profile.collision.traverse_s + w.profile.collision.project_s;
    w.pair_sample_next_ = (w.pair_sample_next_ + 1) % World::kPairSamples;
    std::array<double, World::kPairSamples> sorted = w.pair_samples_;
    std::nth_element(sorted.begin(), sorted.begin() + World::kPairSamples / 2, sorted.end());
    w.last_pairs_s_ = sorted[World::kPairSamples / 2];
    w.last_pairs_traversed_ = w.profile.work.pairs_traversed;
  }
  w.profile.work.pairs_from_cache = w.profile.collision.cache_hits;
  w.profile.work.node_tests = w.profile.collision.node_pairs;
  w.profile.traverse = w.profile.collision.traverse_s;
  w.profile.interpenetration = w.profile.collision.project_s;
  w.profile.detect = std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace gs
