// Collision detection stage: refit the deformed bodies' trees, then a broad
// phase on root spheres and the paper's two-tree traversal with MLS projection
// for every pair that may touch (collision.h). Pairs of bodies that cannot move
// (fixed or kinematic against fixed or kinematic) are not tested, nor pairs of
// sleeping bodies (sleep.cpp).
#include <chrono>

#include "core/world.h"

namespace gs {

void DetectCollisions(World& w) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  // refit only the trees whose control points moved
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
  const auto t1 = Clock::now();
  w.profile.refit = std::chrono::duration<double>(t1 - t0).count();

  w.contacts.Clear();
  const int n = static_cast<int>(w.bodies.size());
  for (int i = 0; i < n; ++i) {
    const Body& a = w.bodies[i];
    const CollisionShape sa = a.Shape();
    for (int j = i + 1; j < n; ++j) {
      const Body& b = w.bodies[j];
      const bool a_moves = a.articulation >= 0, b_moves = b.articulation >= 0;
      if (!a_moves && !b_moves) continue;
      // two fingertips of one finger, segments of one tracked finger (World::CanTouch)
      if (!w.CanTouch(i, j)) continue;
      ++w.profile.work.body_pairs;
      // at rest (sleep.cpp): the last step's contacts, moved with the poses
      if (PairAsleep(w, i, j)) {
        ReuseContacts(w, i, j);
        continue;
      }
      const CollisionShape sb = b.Shape();
      ++w.profile.work.pair_tests;
      if (!RootsOverlap(sa, a.pose, sb, b.pose, w.params.collision.contact_threshold)) continue;
      ++w.profile.work.pairs_traversed;
      PairCache* cache = w.pair_caches.empty() ? nullptr : &w.pair_caches[static_cast<size_t>(i) * n + j];
      CollidePair(i, sa, a.pose, j, sb, b.pose, w.params.collision, &w.collision_scratch, &w.contacts,
                  &w.profile.collision, cache);
    }
  }
  w.profile.work.pairs_from_cache = w.profile.collision.cache_hits;
  w.profile.work.node_tests = w.profile.collision.node_pairs;
  w.profile.traverse = w.profile.collision.traverse_s;
  w.profile.interpenetration = w.profile.collision.project_s;
}

}  // namespace gs
