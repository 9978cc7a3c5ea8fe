#include "core/collision.h"

#include <algorithm>
#include <optional>
#include <chrono>
#include <cmath>
#include <limits>


namespace gs {
namespace {

using Clock = std::chrono::steady_clock;

// bound on how much one projection fit shrinks the distance to the surface's foot
constexpr double kContraction = 0.05;
// a pair cache's first capacity (leaf pairs): its lists grow from there as needed
constexpr size_t kPairListStart = 4096;
// ProjectNear's `far` when every projection must run to convergence
constexpr double kNoFarStop = std::numeric_limits<double>::infinity();
// subtrees of at most this many nodes (8 leaves) are scanned, not descended, against a leaf
constexpr int kScanNodes = 15;
// a leaf patch within this fraction of the bandwidth of the MLS surface over its
// leaf stands for the surface there (0.3% of h is 0.5% of the point spacing)
constexpr double kPatchExact = 3e-3;
// a contact deeper than this fraction of the bandwidth must have its foot's
// normal within acos(kFacingCos) of facing the query leaf's normal
constexpr double kDeepFraction = 0.1;
constexpr double kFacingCos = 0.25;
// a leaf whose point normals are all within 3 degrees of their mean is flat, one
// whose normals spread beyond 30 degrees holds a sharp edge; in between it is
// smoothly curved
constexpr double kFlatCos = 0.9986;
constexpr double kSharpCos = 0.866;

bool SmoothlyCurved(const SphereTree& t, int leaf) {
  const double c = t.leaf_flatness(leaf);
  return c > kSharpCos && c <= kFlatCos;
}

double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// a node pair as one word of the traversal stack, and back
uint64_t PackPair(int a, int b) { return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) | static_cast<uint32_t>(b); }
int PairFirst(uint64_t p) { return static_cast<int>(static_cast<uint32_t>(p >> 32)); }
int PairSecond(uint64_t p) { return static_cast<int>(static_cast<uint32_t>(p)); }

// moves the nodes of a tree into another frame, for traversal
void MoveNodes(const SphereTree& t, const Pose& to, std::vector<TraversalNode>* out) {
  const TraversalNode* n = t.traversal();
  const size_t count = t.nodes().size();
  out->resize(count);  // capacity reserved: no allocation
  TraversalNode* o = out->data();
  for (size_t i = 0; i < count; ++i) {
    o[i] = n[i];
    o[i].center = to.R * n[i].center + to.t;
  }
}

// Descends two trees whose nodes are in one frame from the node pairs on `stack`
// (each found overlapping within `threshold` when pushed): every overlapping leaf
// pair goes to emit(ia, ib, d2, d), every other overlapping pair on the stack.
// Stops when the stack is empty or after at least `max_tests` sphere tests (the
// stack then holds the rest); returns the tests done.
template <class Emit>
int Descend(const TraversalNode* na, const int* end_a, const TraversalNode* nb, const int* end_b, double threshold,
            std::vector<uint64_t>* stack, int max_tests, Emit&& emit) {
  int tests = 0;
  // tests (ia, ib): overlapping leaf pairs are emitted, other overlapping pairs stacked
  auto visit = [&](int ia, int ib) {
    const TraversalNode& a = na[ia];
    const TraversalNode& b = nb[ib];
    const double reach = a.radius + b.radius + threshold;
    const Vec3 d = a.center - b.center;
    const double d2 = d.squaredNorm();
    ++tests;
    if (d2 > reach * reach) return;
    if (a.IsLeaf() && b.IsLeaf())
      emit(ia, ib, d2, d);
    else
      stack->push_back(PackPair(ia, ib));
  };
  while (!stack->empty() && tests < max_tests) {
    const uint64_t top = stack->back();
    stack->pop_back();
    const int ia = PairFirst(top), ib = PairSecond(top);
    const TraversalNode& a = na[ia];
    const TraversalNode& b = nb[ib];
    // descend the larger node; a small subtree against a leaf is scanned: its
    // leaves, a contiguous node range, are tested one after the other
    if (b.IsLeaf() || (!a.IsLeaf() && a.radius >= b.radius)) {
      if (b.IsLeaf() && end_a[ia] - ia <= kScanNodes) {
        for (int k = ia + 1; k < end_a[ia]; ++k)
          if (na[k].IsLeaf()) visit(k, ib);
      } else {
        visit(a.child[1], ib);
        visit(a.child[0], ib);
      }
    } else {
      if (a.IsLeaf() && end_b[ib] - ib <= kScanNodes) {
        for (int k = ib + 1; k < end_b[ib]; ++k)
          if (nb[k].IsLeaf()) visit(ia, k);
      } else {
        visit(ia, b.child[1]);
        visit(ia, b.child[0]);
      }
    }
  }
  return tests;
}

// starts a descent at the root pair: tested, then emitted (two single-leaf trees)
// or stacked when it overlaps; returns the test done
template <class Emit>
int SeedDescent(const TraversalNode* na, int root_a, const TraversalNode* nb, int root_b, double threshold,
                std::vector<uint64_t>* stack, Emit&& emit) {
  stack->clear();
  const double reach = na[root_a].radius + nb[root_b].radius + threshold;
  const Vec3 d = na[root_a].center - nb[root_b].center;
  const double d2 = d.squaredNorm();
  if (d2 > reach * reach) return 1;
  if (na[root_a].IsLeaf() && nb[root_b].IsLeaf())
    emit(root_a, root_b, d2, d);
  else
    stack->push_back(PackPair(root_a, root_b));
  return 1;
}

// collects the overlapping leaf pairs of two trees whose nodes are in one frame
void TraverseTrees(const TraversalNode* na, const int* end_a, int root_a, const TraversalNode* nb, const int* end_b,
                   int root_b, double threshold, CollisionScratch* s, CollisionStats* stats) {
  s->pairs.clear();
  auto emit = [&](int ia, int ib, double d2, const Vec3& d) { s->pairs.push_back({na[ia].leaf(), nb[ib].leaf(), d2, d}); };
  int tests = SeedDescent(na, root_a, nb, root_b, threshold, &s->stack, emit);
  tests += Descend(na, end_a, nb, end_b, threshold, &s->stack, std::numeric_limits<int>::max(), emit);
  stats->node_pairs += tests;
  stats->leaf_pairs += static_cast<int>(s->pairs.size());
}

// how far the moved tree's nodes may have gone since a list was built at `then`
// (the trees' growth_drift() da, db), plus how much any radius may have grown since
double UsedMargin(const Pose& moved, const Pose& then, double da, double db, double extent, const SphereTree& ta,
                  const SphereTree& tb) {
  return (moved.R - then.R).norm() * extent + (moved.t - then.t).norm() + (ta.growth_drift() - da) +
         (tb.growth_drift() - db);
}

// the emitter of a list's traversal: node pairs, until the list would outgrow
// `limit` (it is then marked invalid and not kept)
struct IntoList {
  PairList* list;
  size_t limit;
  void operator()(int ia, int ib, double, const Vec3&) const {
    if (list->pairs.size() < limit)
      list->pairs.emplace_back(ia, ib);
    else
      list->valid = false;
  }
};

// a list begins: empty, at the current pose and growth, with its margin
void BeginList(PairList* list, const Pose& moved, double margin, const SphereTree& ta, const SphereTree& tb) {
  list->pairs.clear();
  list->valid = true;
  list->moved = moved;
  list->margin = margin;
  list->drift_a = ta.growth_drift();
  list->drift_b = tb.growth_drift();
}

// the next wide list is done: it becomes the wide list (a list that outgrew its
// capacity ends the pair's wide lists: every refill then descends the trees)
void PromoteNext(PairCache* c) {
  std::swap(c->wide, c->next);
  c->building = false;
  c->next_stack.clear();
  c->wide_age = c->next_age;
  c->wide_tests = c->next_tests;
  c->wide_used = -1.0;  // not yet seen
  if (!c->wide.valid) c->wide_limit = 0;
}

// One-pass contact: for each leaf of the querying body (a's when query_a) that the
// pairs reach, its coupled leaf on the surface body (the overlapping leaf whose centre
// is nearest) and its lift (its lowest height above the overlapping leaves' slabs),
// what the two-sided gathering in CollidePair gives that side, in the same order.
// `normals`: the surface's leaf normals in the traversal's frame.
struct SideGather {
  bool query_a;
  const SphereTree* ts;
  const Vec3* normals;
  int* bl;
  double* bd;
  double* lf;
  std::vector<int>* touched;
  SideGather(bool q, const SphereTree& t, const Vec3* n, std::vector<int>* best, std::vector<double>* best_d2,
             std::vector<double>* lift, std::vector<int>* touched_leaves)
      : query_a(q), ts(&t), normals(n), bl(best->data()), bd(best_d2->data()), lf(lift->data()),
        touched(touched_leaves) {}
  /// one overlapping leaf pair: d is a's centre minus b's, dist2 its squared norm
  void Add(int leaf_a, int leaf_b, double dist2, const Vec3& d) const {
    // b's height above a's slab is -d . n_a
    const int lq = query_a ? leaf_a : leaf_b;
    const int ls = query_a ? leaf_b : leaf_a;
    const double h = (query_a ? 1.0 : -1.0) * d.dot(normals[ls]) - ts->leaf_height(ls);
    if (bl[lq] < 0) {
      touched->push_back(lq);
      lf[lq] = h;
      bl[lq] = ls;
      bd[lq] = dist2;
      return;
    }
    lf[lq] = std::min(lf[lq], h);
    if (dist2 < bd[lq]) {
      bl[lq] = ls;
      bd[lq] = dist2;
    }
  }
};

void GatherSide(const std::vector<CollisionScratch::LeafPair>& pairs, const SideGather& g) {
  for (const CollisionScratch::LeafPair& p : pairs) g.Add(p.leaf_a, p.leaf_b, p.dist2, p.d);
}

// The overlapping leaf pairs of two trees (into s->pairs, as TraverseTrees gives
// them) from their PairCache: served from its list while the motion stays within
// the list's margin, else the list refilled from the wide list, or rebuilt by a
// traversal; then a slice of the next wide list. With a one-pass `gather`, pairs
// served from the list go straight to it instead of into s->pairs (a held grasp
// serves tens of thousands a step, not written out and read back); returns true then.
bool CachedLeafPairs(const TraversalNode* na, const TraversalNode* nb, const SphereTree& ta, const SphereTree& tb,
                     bool in_b, const Pose& moved_pose, const CollisionParams& params, PairCache* cache,
                     CollisionScratch* s, CollisionStats* local, const SideGather* gather, double* spare) {
  const double thr = params.contact_threshold;
  const double extent = (in_b ? ta : tb).center_extent();
  const double radii = ta.mean_leaf_radius() + tb.mean_leaf_radius();
  const double margin = params.pair_cache_margin * radii;
  const double wide_margin = params.pair_cache_wide_margin * radii;
  const int* end_a = ta.span_end();
  const int* end_b = tb.span_end();
  if (cache->in_b != in_b) cache->Invalidate();
  cache->in_b = in_b;
  // once per pair, unless World::Finalize did it (core/collision.h, PairCache)
  if (!cache->reserved) cache->ReserveStart(std::max(ta.nodes().size(), tb.nodes().size()));
  auto used = [&](const Pose& then, double da, double db) {
    return UsedMargin(moved_pose, then, da, db, extent, ta, tb);
  };
  auto used_list = [&](const PairList& l) { return used(l.moved, l.drift_a, l.drift_b); };
  const bool wide_on = cache->wide_limit > 0 && wide_margin > margin;
  bool fused = false;
  // the next wide list's nodes: the moved tree's as they were when it began
  const TraversalNode* next_a = in_b ? cache->next_nodes.data() : na;
  const TraversalNode* next_b = in_b ? nb : cache->next_nodes.data();

  const double used_served = cache->valid ? used(cache->moved, cache->drift_a, cache->drift_b) : 0.0;
  *spare = -std::numeric_limits<double>::infinity();
  if (cache->valid && used_served <= cache->margin) {
    // served: every pair a traversal would find now is in the list, and the pairs
    // left out of it are farther apart than the threshold by what is left of its
    // margin. A pair of the list that does not overlap keeps the control point of
    // each leaf (its centre, where its contacts are made) beyond the threshold from
    // the other leaf's sphere by the centres' distance less the larger radius.
    s->pairs.clear();
    int overlapping = 0;
    double apart = cache->margin - used_served;
    for (const auto& [ia, ib] : cache->pairs) {
      const TraversalNode& x = na[ia];
      const TraversalNode& y = nb[ib];
      const double reach = x.radius + y.radius + thr;
      const Vec3 d = x.center - y.center;
      const double d2 = d.squaredNorm();
      if (d2 > reach * reach) {
        const double near = std::max(x.radius, y.radius) + thr;
        if (d2 < (near + apart) * (near + apart)) apart = std::sqrt(d2) - near;
        continue;
      }
      ++overlapping;
      if (gather)
        gather->Add(x.leaf(), y.leaf(), d2, d);
      else
        s->pairs.push_back({x.leaf(), y.leaf(), d2, d});
    }
    local->node_pairs += static_cast<int>(cache->pairs.size());
    local->leaf_pairs += overlapping;
    ++local->cache_hits;
    fused = gather != nullptr;
    *spare = apart;
  } else {
    bool from_wide = false, traversed = false;
    if (wide_on) {
      // the wide list covers the pairs within the served margin while its own
      // margin holds the motion since plus the served margin
      from_wide = cache->wide.valid && used_list(cache->wide) + margin <= cache->wide.margin;
      if (!from_wide && cache->building && used_list(cache->next) + margin <= cache->next.margin) {
        // the slices did not finish in time: the rest of the next wide list now
        const int t = Descend(next_a, end_a, next_b, end_b, thr + cache->next.margin, &cache->next_stack,
                              std::numeric_limits<int>::max(), IntoList{&cache->next, cache->wide_limit});
        local->node_pairs += t;
        cache->next_tests += t;
        PromoteNext(cache);
        from_wide = cache->wide.valid;
        traversed = true;
      }
      if (!from_wide && cache->wide_limit > 0) {
        // a whole traversal with the wide margin, from the current pose
        cache->building = false;
        PairList& w = cache->wide;
        BeginList(&w, moved_pose, wide_margin, ta, tb);
        const IntoList emit{&w, cache->wide_limit};
        int t = SeedDescent(na, ta.root(), nb, tb.root(), thr + wide_margin, &s->stack, emit);
        t += Descend(na, end_a, nb, end_b, thr + wide_margin, &s->stack, std::numeric_limits<int>::max(), emit);
        local->node_pairs += t;
        cache->wide_tests = t;
        cache->wide_age = 0;
        cache->wide_used = 0.0;
        if (!w.valid) cache->wide_limit = 0;
        from_wide = w.valid;
        traversed = true;
      }
    }
    if (from_wide) {
      // refill: the wide list's pairs within the served margin now, and of those
      // the pairs within reach
      s->pairs.clear();
      cache->pairs.clear();
      bool fits = true;
      for (const auto& [ia, ib] : cache->wide.pairs) {
        const TraversalNode& x = na[ia];
        const TraversalNode& y = nb[ib];
        const double reach = x.radius + y.radius + thr;
        const double wider = reach + margin;
        const Vec3 d = x.center - y.center;
        const double d2 = d.squaredNorm();
        if (d2 > wider * wider) continue;
        if (cache->pairs.size() < cache->limit)
          cache->pairs.emplace_back(ia, ib);
        else
          fits = false;
        if (d2 <= reach * reach) s->pairs.push_back({x.leaf(), y.leaf(), d2, d});
      }
      local->node_pairs += static_cast<int>(cache->wide.pairs.size());
      cache->valid = fits;
      cache->moved = moved_pose;
      cache->margin = margin;
      cache->drift_a = ta.growth_drift();
      cache->drift_b = tb.growth_drift();
      local->leaf_pairs += static_cast<int>(s->pairs.size());
      ++(traversed ? local->cache_builds : local->cache_refills);
    } else {
      // traverse with the served margin, keep the list, then keep the pairs within reach
      CollisionStats traversal;
      TraverseTrees(na, end_a, ta.root(), nb, end_b, tb.root(), thr + margin, s, &traversal);
      local->node_pairs += traversal.node_pairs;
      cache->valid = s->pairs.size() <= cache->limit;
      if (cache->valid) {
        cache->pairs.clear();
        for (const CollisionScratch::LeafPair& p : s->pairs)
          cache->pairs.emplace_back(ta.leaf_node(p.leaf_a), tb.leaf_node(p.leaf_b));
        cache->moved = moved_pose;
        cache->margin = margin;
        cache->drift_a = ta.growth_drift();
        cache->drift_b = tb.growth_drift();
      }
      size_t kept = 0;
      for (const CollisionScratch::LeafPair& p : s->pairs) {
        const double reach = na[ta.leaf_node(p.leaf_a)].radius + nb[tb.leaf_node(p.leaf_b)].radius + thr;
        if (p.dist2 <= reach * reach) s->pairs[kept++] = p;
      }
      s->pairs.resize(kept);
      local->leaf_pairs += static_cast<int>(kept);
      ++local->cache_builds;
    }
  }

  // ahead of need: once half the wide list's spare margin is used, the next wide
  // list begins from the current pose; then every step that served its list
  // traverses a slice of it, sized to end it when half the margin left is used at
  // the pace of the motion so far (counted in tests and margins: no clock)
  if (wide_on && cache->wide.valid && cache->wide_limit > 0) {
    ++cache->wide_age;
    if (cache->building) ++cache->next_age;
    const double spare = cache->wide.margin - margin;
    const double used_wide = used_list(cache->wide);
    if (!cache->building && used_wide > 0.5 * spare) {
      BeginList(&cache->next, moved_pose, wide_margin, ta, tb);
      cache->next_nodes.assign(s->moved.begin(), s->moved.end());  // capacity reserved: no allocation
      const int t = SeedDescent(next_a, ta.root(), next_b, tb.root(), thr + wide_margin, &cache->next_stack,
                                IntoList{&cache->next, cache->wide_limit});
      local->node_pairs += t;
      local->slice_tests += t;
      cache->next_tests = t;
      cache->next_age = 0;
      cache->building = true;
    }
    // margin used per step: on average since the wide list's pose, or in the last
    // step when the motion speeds up
    const double pace =
        std::max(used_wide / cache->wide_age, cache->wide_used >= 0.0 ? used_wide - cache->wide_used : 0.0);
    cache->wide_used = used_wide;
    if (cache->building && local->cache_hits > 0) {
      const double steps_left = pace > 0.0 ? 0.5 * (spare - used_wide) / pace : 1e9;
      // the tests left: what the last wide list took, less what is done, and at
      // least a quarter of it more (a contact that spreads takes more than the last)
      const double left = std::max(cache->wide_tests - cache->next_tests, cache->wide_tests / 4);
      const int slice = static_cast<int>(std::min(1e9, std::max<double>(params.pair_cache_slice_tests,
                                                                       std::ceil(left / std::max(1.0, steps_left)))));
      const int t = Descend(next_a, end_a, next_b, end_b, thr + cache->next.margin, &cache->next_stack, slice,
                            IntoList{&cache->next, cache->wide_limit});
      local->node_pairs += t;
      local->slice_tests += t;
      cache->next_tests += t;
      if (cache->next_stack.empty()) PromoteNext(cache);
    }
  }
  return fused;
}

// the leaf whose centre is nearest to p, by greedy descent (exact enough for a re-projection)
int NearestLeaf(const SphereTree& t, const Vec3& p) {
  const TraversalNode* n = t.traversal();
  int i = t.root();
  while (!n[i].IsLeaf()) {
    const int c0 = n[i].child[0], c1 = n[i].child[1];
    const double d0 = (n[c0].center - p).norm() - n[c0].radius;
    const double d1 = (n[c1].center - p).norm() - n[c1].radius;
    i = d0 <= d1 ? c0 : c1;
  }
  return n[i].leaf();
}

// Every point within the kernel's support of q: the neighbourhood of *leaf while q
// lies in its sphere (it holds the points within radius + border of the centre),
// else the points of every leaf whose sphere reaches q's support ball (a query
// off the surface, deep or at an edge), gathered into ball (capacity kept).
const int* SupportOf(const SphereTree& ts, const Vec3& q, double support, int* leaf, int* count, CollisionScratch* s) {
  const TreeNode& node = ts.node(ts.leaf_node(*leaf));
  if ((q - node.center).squaredNorm() <= node.rest_radius * node.rest_radius) return ts.neighbourhood(*leaf, count);
  *leaf = NearestLeaf(ts, q);
  const TreeNode& near = ts.node(ts.leaf_node(*leaf));
  if ((q - near.center).squaredNorm() <= near.rest_radius * near.rest_radius) return ts.neighbourhood(*leaf, count);
  s->ball.clear();
  s->node_stack.clear();
  s->node_stack.push_back(ts.root());
  const int* order = ts.point_order().data();
  const size_t cap = s->ball.capacity();
  while (!s->node_stack.empty()) {
    const TreeNode& n = ts.node(s->node_stack.back());
    s->node_stack.pop_back();
    const double reach = n.rest_radius + support;
    if ((q - n.center).squaredNorm() > reach * reach) continue;
    if (n.IsLeaf()) {
      for (int k = n.first; k < n.first + n.count && s->ball.size() < cap; ++k) s->ball.push_back(order[k]);
    } else if (s->node_stack.size() + 2 <= s->node_stack.capacity()) {
      s->node_stack.push_back(n.child[1]);
      s->node_stack.push_back(n.child[0]);
    }
  }
  *count = static_cast<int>(s->ball.size());
  return s->ball.data();
}

// Whether x stands outside the surface near leaf l by more than `far`, told by the
// leaf's fit (trusted or not): x outside the fit by more than `far` plus twice the
// fit's error over the leaf (sampled at build), its closest point on the fit inside
// the leaf's sphere, where that error was measured.
bool FarAboveFit(const SphereTree& ts, int l, const Vec3& x, double h, double far, double* outside) {
  const MlsPatch* fit = ts.leaf_fit(l);
  if (!fit || fit->h != h) return false;
  const double margin = 2.0 * ts.leaf_fit_error(l);
  const Vec3 q = fit->Closest(x);
  const TreeNode& node = ts.node(ts.leaf_node(l));
  if (!q.allFinite() || !((q - node.center).squaredNorm() <= node.rest_radius * node.rest_radius)) return false;
  *outside = (x - q).dot(fit->NormalBelow(q)) - margin;
  return *outside > far;
}

// Projects x onto the MLS surface of the surface body near its leaf *leaf, what
// ProjectOntoSurface does over all the body's points: every fit sees every point
// within the kernel's support (the leaf follows the iterate). Where the leaf's
// cached patch is trusted (a smooth surface there, on which the foot of x is the
// same from any start near it) the fits start on the patch's point closest to x, usually one
// fit from converged; elsewhere (sharp edges, a capsule's rim) they start at `warm`
// when given (the foot of a nearby earlier x: the same foot the start at x found,
// moved with x) or else at x, like the reference.
bool ProjectNear(const SphereTree& ts, const Vec3* pos, const Vec3* nrm, const Vec3& x, const MlsParams& mls,
                 double far, int* leaf, CollisionScratch* s, MlsProjection* out, const Vec3* warm) {
  const double support = mls.support * mls.bandwidth;
  const MlsPatch* patch = ts.leaf_patch(*leaf);
  Vec3 q = patch ? patch->Closest(x) : (warm ? *warm : x);
  // Where the leaf's patch was checked at build to stay within kPatchExact * h of
  // the MLS surface over the whole leaf (flat faces, gently curved ones), the
  // foot of x on the patch is its foot on the surface to that accuracy: no fit.
  // A foot that lands in a neighbouring leaf tries that leaf's patch, once.
  if (patch && patch->h == mls.bandwidth) {
    int at = *leaf;
    for (int hop = 0; hop < 2; ++hop) {
      const MlsPatch* p = ts.leaf_patch(at);
      if (!p || !(ts.leaf_patch_error(at) <= kPatchExact * mls.bandwidth)) break;
      const Vec3 f = hop == 0 ? q : p->Closest(x);
      const TreeNode& node = ts.node(ts.leaf_node(at));
      if ((f - node.center).squaredNorm() <= node.rest_radius * node.rest_radius) {
        *leaf = at;
        out->point = f;
        out->normal = p->NormalBelow(f);
        out->converged = true;
        return f.allFinite() && out->normal.allFinite();
      }
      at = NearestLeaf(ts, f);
      if (at == *leaf) break;
    }
  }
  // A fit that strays from the MLS surface by at most e over its leaf (sampled at
  // build: twice that is the margin) puts x's distance to the surface there within 2e
  // of its distance to the fit: a point outside it by more than `far` + 2e has no
  // contact near this leaf, and no MLS fit is needed to say so.
  double outside = 0.0;
  if (FarAboveFit(ts, *leaf, x, mls.bandwidth, far, &outside)) {
    out->iterations = 0;
    out->point = x;
    out->normal = Vec3::UnitZ();
    out->far = true;
    out->outside = outside;
    return true;
  }
  Vec3 normal = Vec3::UnitZ();
  out->iterations = 0;
  out->converged = false;
  int fits = 0;
  for (int attempt = 0; attempt < 2; ++attempt) {
    bool failed = false;
    for (int it = 0; it < mls.max_iterations; ++it) {
      int count = 0;
      const int* idx = SupportOf(ts, q, support, leaf, &count, s);
      Vec3 next;
      ++fits;
      if (!MlsProjectStep(pos, nrm, idx, count, x, q, mls, &next, &normal)) {
        failed = true;
        break;
      }
      const double moved = (next - q).norm();
      q = next;
      // Outside the surface by more than `far` plus what the fits still have to move
      // (in all at most the last move again, at a contraction of 1/2 or better; from
      // a patch's start it is 1/20): no contact, whatever the converged foot. Most
      // projections of a grasp are of points near a curved surface but not on it.
      if ((x - q).dot(normal) - 2.0 * moved > far) {
        out->iterations = fits;
        out->point = q;
        out->normal = normal;
        out->far = true;
        out->outside = (x - q).dot(normal) - 2.0 * moved;
        return q.allFinite() && normal.allFinite();
      }
      // from a trusted patch's start, one fit shrinks the distance to the foot at
      // least 20-fold (measured: the second move is at most 1.1% of the first on
      // the paper's scene), so the point is within tolerance * h once the first
      // move is below 20 times that: the fit that would only confirm it is skipped
      const double slack = (patch && attempt == 0 && it == 0) ? 1.0 / kContraction : 1.0;
      if (moved < slack * mls.tolerance * mls.bandwidth) {
        out->converged = true;
        break;
      }
    }
    if (!failed) {
      out->iterations = fits;
      out->point = q;
      out->normal = normal;
      return q.allFinite() && normal.allFinite();
    }
    if (attempt == 1) break;
    // deep query: restart from its foot on the tangent plane of the nearest point
    int count = 0;
    const int* idx = SupportOf(ts, x, support, leaf, &count, s);
    if (count <= 0) break;
    int nearest = idx[0];
    double best = (pos[nearest] - x).squaredNorm();
    for (int k = 1; k < count; ++k) {
      const double d2 = (pos[idx[k]] - x).squaredNorm();
      if (d2 < best) {
        best = d2;
        nearest = idx[k];
      }
    }
    q = x - (x - pos[nearest]).dot(nrm[nearest]) * nrm[nearest];
  }
  out->iterations = fits;
  return false;
}

// A contact's normal and where it acts: the shift (S's frame) from the projection's
// foot to where the two surfaces touch.
struct PairGeometry {
  Vec3 normal;
  Vec3 shift;
  bool face = false;  ///< a face's point against an edge or a face (FaceOnEdge): normal the face's
  bool beside = false;  ///< a face's point beside S, its foot on a side turned away from the face: no contact
};

// Below this curvature (1/m: radius 1 m) a direction is taken as flat in CommonNormal.
constexpr double kFlatCurvature = 1.0;
// A pair's curvature in one direction below this fraction of its curvature in the
// other: flat there (a line contact or a long ellipse, OffsetFrom)
constexpr double kCurvatureNoise = 0.1;
// normals more than 60 degrees apart are no pair of touching smooth surfaces
constexpr double kMaxPairAngle = M_PI / 3;

// A patch's shape operator (MlsPatch::Shape, 1/m) read along the directions b1, b2
// (the patch's frame), each carried into the patch's tangent plane first: where the
// planes differ by an angle, a plain B^T K B would shrink the curvature by its cos^2.
Eigen::Matrix2d ShapeAlong(const MlsPatch& p, const Vec3& b1, const Vec3& b2) {
  const Vec3 u1 = (b1 - b1.dot(p.normal) * p.normal).normalized();
  const Vec3 u2 = (b2 - b2.dot(p.normal) * p.normal).normalized();
  Eigen::Matrix2d A, K;
  A << u1.dot(p.t1), u2.dot(p.t1), u1.dot(p.t2), u2.dot(p.t2);
  K << 2.0 * p.c[3], p.c[4], p.c[4], 2.0 * p.c[5];
  return A.transpose() * K * A * (-1.0 / p.h);
}

// x solving m x = -phi e1 over the eigen-directions of the symmetric m in which
// the pair is curved: eigenvalue above kFlatCurvature and above kCurvatureNoise
// times the larger one. Along a line contact (a capsule on a cylinder, axes parallel
// or crossing at a small angle) the pair is nearly flat along the line, and there
// the quadrics' touching point lies where two infinite cylinders would cross, past
// the ends of the real bodies: it moved the normal force's lever arm decimetres
// along the line (0.68 m on a tracked hand's phalanx lying across a can). The
// samples spread along the line press where they are instead.
Eigen::Vector2d OffsetFrom(const Eigen::Matrix2d& m, double phi) {
  const double a = m(0, 0), b = m(0, 1), d = m(1, 1);
  const double mean = 0.5 * (a + d), r = std::hypot(0.5 * (a - d), b);
  const double l[2] = {mean + r, mean - r};
  // the eigenvector of the larger eigenvalue at angle t, the smaller's at t + 90 deg
  // (isotropic m, r = 0: any two directions)
  const double t = 0.5 * std::atan2(2.0 * b, a - d);
  const Eigen::Vector2d v[2] = {{std::cos(t), std::sin(t)}, {-std::sin(t), std::cos(t)}};
  Eigen::Vector2d x = Eigen::Vector2d::Zero();
  for (int i = 0; i < 2; ++i)
    if (l[i] > kFlatCurvature && l[i] > kCurvatureNoise * l[0]) x -= v[i] * (phi * v[i].x() / l[i]);
  return x;
}

// The common normal of two smooth surfaces, from one query point x on Q projected
// onto S. x sits at an unknown tangential offset t from where the surfaces touch:
// the foot's normal n_s has turned by K_s t from the common normal n0, Q's own
// normal at x by K_q t the other way (K the shape operators, turning angles). The
// angle from n_s to -n_q is therefore (K_s + K_q) t, which gives t, and n0 is n_s
// turned back by K_s t toward -n_q. A flat wall's point on a fingertip takes the
// wall's normal, a fingertip's point on the wall the wall's, two equal spheres the
// centre line. Directions in which the pair is flat (or concave) keep n_s's tilt.
// The force acts where the surfaces touch, t from the foot: along n0 but at x, it
// would turn both bodies about the touching point (a rigid fingertip's point 1 mm
// off a cylinder's touching line spun the cylinder, and friction spent on holding
// the spin let it drop at 1.005 mu*). In S's frame (R turns Q's frame into it);
// n_s and n_q unit; ps, pq the leaves' patches (each in its body's frame).
PairGeometry CommonNormal(const Vec3& n_s, const MlsPatch& ps, const Vec3& n_q, const MlsPatch& pq, const Mat3& R) {
  const PairGeometry foot{n_s, Vec3::Zero()};
  const Vec3 w = -n_q - (-n_q).dot(n_s) * n_s;  // toward -n_q, tangent to S
  const double sin_phi = w.norm();
  const double phi = std::atan2(sin_phi, -n_q.dot(n_s));
  if (!(sin_phi > 1e-12) || !(phi < kMaxPairAngle)) return foot;
  const Vec3 b1 = w / sin_phi;
  const Vec3 b2 = n_s.cross(b1);
  const Eigen::Matrix2d ks = ShapeAlong(ps, b1, b2);
  const Eigen::Matrix2d m = ks + ShapeAlong(pq, R.transpose() * b1, R.transpose() * b2);
  const Eigen::Vector2d offset = OffsetFrom(m, phi);  // from the touching point to the foot
  const Eigen::Vector2d turn = -ks * offset;
  const double angle = turn.norm();
  PairGeometry g{n_s, -(offset.x() * b1 + offset.y() * b2)};
  if (angle > 1e-12) g.normal = std::cos(angle) * n_s + (std::sin(angle) / angle) * (turn.x() * b1 + turn.y() * b2);
  return g;
}

// A flat face's point (Q, normal n_q) whose foot on S is near a sharp edge or
// corner (a leaf with no trusted patch) or on a leaf whose patch is flat at its
// centre while the foot, at its border, is already on the MLS surface's rounding
// of an edge: the foot's normal has turned, the face's has not. CommonNormal with
// a flat Q gives -n_q for any curvature of S; at an edge (curvature without
// bound) the touching point is the foot. Between two faces that truly face each
// other -n_q and n_s agree. A box resting on a slab otherwise pressed the slab's
// points under its edges along the rounding's normals, 25 to 34 degrees off. A
// foot on a side turned more than 60 degrees from the face is no touch of the
// face (`beside`): a sliding box's leading side pushed it back through the slab's
// points in front of it.
PairGeometry FaceOnEdge(const Vec3& n_s, const Vec3& n_q) {
  if (!(-n_q.dot(n_s) > std::cos(kMaxPairAngle))) return {n_s, Vec3::Zero(), false, true};
  return {-n_q, Vec3::Zero(), true};
}

// The MLS surface at the foot agrees with its leaf's flat patch to this cosine
// (0.08 degrees): the foot lies on a plane of S, whose normal is then the common
// normal whatever touches it (a face's interior: the two agree to rounding).
constexpr double kOnPlaneCos = 1.0 - 1e-6;

// Whether the foot lies where S is planar: its MLS normal is the flat patch's there.
// On an edge's rounding the MLS normal has turned from the patch's.
bool OnPlane(const MlsPatch& ps, const MlsProjection& proj) {
  return proj.normal.dot(ps.NormalBelow(proj.point)) > kOnPlaneCos;
}

// The contact normal of query leaf lq (Q) projected onto S near leaf ls, and the
// shift from the foot to where the surfaces touch, in S's frame: the common normal
// from both leaves' patches; a face's point (Q flat) against an edge or a flat
// foot takes the face's normal (FaceOnEdge), unless the foot lies on a plane of S
// (OnPlane): a face of S touched by anything pushes along its own normal. A block
// resting on its MLS rims, tilted 0.2 degrees on a slab, otherwise took its own
// tilted face's normal, and on a slope 1 % past the friction angle slid at 0.69 of
// g (sin a - mu cos a); the foot's normal (no shift) when a
// curved Q's leaf or the foot's leaf has no patch. A face's normal is the common
// normal whatever Q's shape; a curved Q on it touches it at Q's lowest point,
// where the shift goes.
PairGeometry PairNormal(const SphereTree& tq, int lq, const Pose& q_to_s, const SphereTree& ts, int ls,
                        const MlsProjection& proj) {
  const PairGeometry foot{proj.normal, Vec3::Zero()};
  const MlsPatch* pq = tq.leaf_patch(lq);
  const MlsPatch* ps = ts.leaf_patch(ls);
  const auto flat = [](const double* k, double h) {
    return !(std::abs(k[3]) + std::abs(k[4]) + std::abs(k[5]) > 0.5 * kFlatCurvature * h);
  };
  // Q's point on a face: its patch flat or, untrusted, its leaf's normals within 3 degrees
  const bool face_q = pq ? flat(pq->c, pq->h) : tq.leaf_flatness(lq) > kFlatCos;
  if (face_q && (!ps || flat(ps->c, ps->h))) {
    const Vec3 n_q = pq ? pq->NormalBelow(tq.control_point(lq)) : tq.leaf_normal(lq);
    const PairGeometry g = FaceOnEdge(proj.normal, q_to_s.R * n_q);
    return !g.beside && ps && OnPlane(*ps, proj) ? foot : g;
  }
  if (!pq || !ps) return foot;
  const Vec3 n_q = q_to_s.R * pq->NormalBelow(tq.control_point(lq));
  const PairGeometry g = CommonNormal(proj.normal, *ps, n_q, *pq, q_to_s.R);
  return g.normal.allFinite() && g.shift.allFinite() ? g : foot;
}

// projects the control points of the query body onto the surface body's MLS surface
// for every query leaf that has a coupled leaf in best[]; consumes `touched`
// The edge rule of CollisionParams::edge_rule: the query's leaf lq is on a flat face
// (its patch trusted, its normals within 3 degrees) and the foot's leaf ls on the
// surface is shaped by an edge (its patch untrusted)
bool FlatOnEdge(const SphereTree& tq, int lq, const SphereTree& ts, int ls) {
  return std::isfinite(tq.leaf_patch_error(lq)) && tq.leaf_flatness(lq) > kFlatCos &&
         !std::isfinite(ts.leaf_patch_error(ls));
}

// Whether a control point now at x (the surface's frame), coupled to leaf ls, is
// known to give no contact from what an earlier projection proved (its mark): coupled
// to the same leaf, it has moved less than the margin by which it stood beyond the
// threshold. The distance to a surface changes by at most the distance moved.
bool Remembered(const PairCache::FarMark& m, const Vec3& x, int ls, double thr) {
  if (m.coupled != ls) return false;
  const double spare = m.outside - thr;
  return spare > 0.0 && (x - m.x).squaredNorm() < spare * spare;
}

// Whether a control point now at x, coupled to leaf ls, has a foot in its mark found
// while coupled to the same leaf, less than r from x.
bool FootWithin(const PairCache::FarMark& m, const Vec3& x, int ls, double r) {
  return m.foot_leaf >= 0 && m.coupled == ls && (x - m.x).squaredNorm() < r * r;
}

// Whether the point keeps that foot: it has moved less than `keep`, what a converged
// foot may be off already. Its distance to the surface then changes by the motion
// along the normal, to second order in the motion.
bool KeepsFoot(const PairCache::FarMark& m, const Vec3& x, int ls, double keep) { return FootWithin(m, x, ls, keep); }

// the start of a control point's next projection: its kept foot while it is within
// a tenth of the bandwidth of where the foot was found, else none
const Vec3* WarmStart(const PairCache::FarMark& m, const Vec3& x, int ls, double h) {
  return FootWithin(m, x, ls, 0.1 * h) ? &m.foot : nullptr;
}

// How far a converged projection's gap may be from the distance to the MLS surface:
// a patch's error over its leaf when the patch served it (no fit), else what the
// fits still had to move (below the tolerance, 20 times that after a trusted start).
double FootError(const SphereTree& ts, int coupled, const MlsProjection& proj, const MlsParams& mls) {
  if (proj.iterations == 0) return ts.leaf_patch_error(coupled);
  return 2.0 * mls.tolerance * mls.bandwidth / kContraction;
}

void ProjectSide(int id_q, const SphereTree& tq, const Pose& q_to_s, int id_s, const CollisionShape& surf,
                 const Pose& pose_s, const CollisionParams& params, bool emit, bool two_pass, bool rigid_pair,
                 std::vector<int>* best,
                 std::vector<double>* best_d2, std::vector<double>* lift, std::vector<int>* touched,
                 std::vector<PairCache::FarMark>* marks, CollisionScratch* s, ContactBuffer* out,
                 CollisionStats* stats, double* spare) {
  const SphereTree& ts = *surf.tree;
  constexpr double kUnknown = -std::numeric_limits<double>::infinity();
  // the least any control point is proven to stand beyond the threshold (PairCache::clear)
  auto apart = [spare](double d) { *spare = std::min(*spare, d); };
  const double thr = params.contact_threshold;
  // a point whose projection proves nothing (failed, rejected) is still apart by its
  // distance to the surface's leaf spheres, while the pair may yet prove clear
  auto unproven = [&](const Vec3& x) {
    const bool open = stats->contacts == 0 && *spare > 0.0;  // stats: the pair's own
    apart(open ? SphereDistanceBound(ts, x, s) - thr : kUnknown);
  };
  // the marks serve where every projection is the closest-point one at the body's bandwidth
  PairCache::FarMark* mark = marks && params.far_memory && params.far_stop && params.max_bandwidth_factor <= 1.0 &&
                                     marks->size() >= static_cast<size_t>(tq.num_leaves())
                                 ? marks->data()
                                 : nullptr;
  const Vec3* pos = surf.cloud->positions.data();
  const Vec3* nrm = surf.cloud->normals.data();
  const double h = surf.mls.bandwidth;
  MlsParams mls = surf.mls;
  // feet are kept where the marks serve (at the body's own bandwidth)
  const bool feet = mark && params.foot_memory;
  const double keep = kContraction * mls.tolerance * h;
  for (int lq : *touched) {
    const int ls = (*best)[lq];
    const double d2 = (*best_d2)[lq];
    const double above = (*lift)[lq];
    (*best)[lq] = -1;
    (*best_d2)[lq] = std::numeric_limits<double>::infinity();
    (*lift)[lq] = std::numeric_limits<double>::infinity();
    if (ls < 0 || !emit) continue;
    // above the slab of every overlapping leaf by more than delta_eps: no surface within delta_eps
    if (above > params.contact_threshold) {
      ++stats->culled;
      apart(above - thr);
      continue;
    }
    // bandwidth from the distance between the coupled centres, clamped to the body's range
    mls.bandwidth = std::clamp(std::sqrt(d2), h, params.max_bandwidth_factor * h);
    const Vec3 x = q_to_s.Apply(tq.control_point(lq));
    if (mark && Remembered(mark[lq], x, ls, thr)) {
      ++stats->remembered;
      apart(mark[lq].outside - (x - mark[lq].x).norm() - thr);
      continue;
    }
    MlsProjection proj;
    int coupled = ls;
    const bool kept = feet && KeepsFoot(mark[lq], x, ls, keep);
    if (kept) {
      ++stats->feet_kept;
      proj.point = mark[lq].foot;
      proj.normal = mark[lq].normal;
      proj.converged = true;
      coupled = mark[lq].foot_leaf;
    } else {
      ++stats->projections;
      const bool ok = ProjectNear(ts, pos, nrm, x, mls, params.far_stop ? params.contact_threshold : kNoFarStop,
                                  &coupled, s, &proj, feet ? WarmStart(mark[lq], x, ls, h) : nullptr);
      stats->fits += proj.iterations;
      if (ok && proj.far) {
        ++stats->far;
        if (mark) mark[lq] = {x, proj.outside, ls};
        apart(proj.outside - thr);
        continue;
      }
      if (!ok || !proj.point.allFinite() || !proj.normal.allFinite()) {
        ++stats->rejected;
        if (mark) mark[lq] = {};
        unproven(x);
        continue;
      }
      // its foot when converged (how far outside x stands is known once it gives no contact)
      if (mark) mark[lq] = {x, -std::numeric_limits<double>::infinity(), ls, proj.converged ? coupled : -1, proj.point,
                            proj.normal};
    }
    // a projection outside the coupled node's border is a curvature artefact (the
    // node coupled by the traversal, not the leaf the projection ended in)
    // (a point rejected for the shape of its foot proves nothing about how near it is)
    if (params.curvature_rejection && !WithinCoupledBorder(ts, ls, proj.point)) {
      ++stats->rejected;
      ++stats->out_of_border;
      unproven(x);
      continue;
    }
    if (two_pass && params.edge_rule && FlatOnEdge(tq, lq, ts, coupled)) {
      ++stats->rejected;
      ++stats->on_edges;
      unproven(x);
      continue;
    }
    const double gap = (x - proj.point).dot(proj.normal);  // eq. 4: negative inside
    // Surfaces in contact face each other. Where a flat face crosses another body's
    // flat face at an angle (a box's top face inside a box dropped on it, near that
    // box's side face), a point deeper than its distance to the adjacent face finds
    // its closest foot there, its normal across the query's own: such a contact
    // pushes sideways where the bodies press along their normals, and two of them
    // on opposite sides of the upper box ask for opposite motions, which no force
    // satisfies. Between piecewise-flat surfaces (faces and sharp edges) it is
    // dropped: the faces that do face each other give that overlap through their
    // own contacts. Where either surface is smoothly curved, the normal turns with
    // the foot and a foot across the query's normal is the true closest point.
    if (gap < -kDeepFraction * h && proj.normal.dot(q_to_s.R * tq.leaf_normal(lq)) > -kFacingCos &&
        !SmoothlyCurved(tq, lq) && !SmoothlyCurved(ts, coupled)) {
      ++stats->rejected;
      unproven(x);
      continue;
    }
    if (!(gap < params.contact_threshold)) {
      // a kept foot: what its projection may have been off by, and the motion since
      const double error = kept ? 2.0 * mls.tolerance * h / kContraction + keep : FootError(ts, coupled, proj, mls);
      const double outside = gap - error;
      if (mark && !kept) mark[lq].outside = outside;
      apart(outside - thr);
      continue;
    }
    Contact c;
    c.body[0] = id_q;
    c.body[1] = id_s;
    c.leaf = lq;
    c.surface_leaf = coupled;
    PairGeometry pg = params.common_normal ? PairNormal(tq, lq, q_to_s, ts, coupled, proj)
                                           : PairGeometry{proj.normal, Vec3::Zero()};
    // a face's point beside a side of S turned away from it touches nothing; against
    // an edge its gap is measured along the face's normal: beside the footprint of
    // S the rounding's foot is level with it, no support below S
    if (pg.beside) {
      ++stats->rejected;
      unproven(x);
      continue;
    }
    const double gap_n = pg.face ? (x - proj.point).dot(pg.normal) : gap;
    if (!(gap_n < params.contact_threshold)) {
      unproven(x);
      continue;
    }
    // Between rigid surfaces the anchors move to the touching point. Deforming
    // surfaces conform over a patch: each sample presses where it is, its eq. 8
    // weights and friction stay there, and only its normal force's lever arm for the
    // bodies' rigid motion ends at the touching point (Contact::touch).
    const Vec3 shift_q = q_to_s.R.transpose() * pg.shift;
    c.anchor[0] = tq.control_point(lq);
    c.anchor[1] = proj.point;
    if (rigid_pair) {
      c.anchor[0] += shift_q;
      c.anchor[1] += pg.shift;
    } else {
      c.touch[0] = shift_q;
      c.touch[1] = pg.shift;
    }
    c.normal = pose_s.Rotate(pg.normal);
    c.gap = gap_n;
    c.key = ContactKey(id_q, id_s, lq);
    if (out->Push(c)) ++stats->contacts;
    apart(kUnknown);
  }
  touched->clear();
}

// Where a curved query leaf's surface touches a plane of normal n (Q's frame): the
// tangential shift from its control point, the common normal's (CommonNormal with a
// flat S, so the normal stays the plane's). A sphere's point off its lowest point
// touches the plane at that lowest point; a face's point, or a leaf without a
// patch, where it is.
Vec3 PlaneTouch(const SphereTree& tq, int lq, const Vec3& n) {
  const MlsPatch* pq = tq.leaf_patch(lq);
  // a face's leaf (PairNormal's test): it touches where it is, at the cost of a branch
  if (!pq || !(std::abs(pq->c[3]) + std::abs(pq->c[4]) + std::abs(pq->c[5]) > 0.5 * kFlatCurvature * pq->h))
    return Vec3::Zero();
  MlsPatch flat;
  flat.normal = n;
  flat.t1 = AnyPerpendicular(n);
  flat.t2 = n.cross(flat.t1);
  const Vec3 n_q = pq->NormalBelow(tq.control_point(lq));
  const PairGeometry g = CommonNormal(n, flat, n_q, *pq, Mat3::Identity());
  if (!g.shift.allFinite()) return Vec3::Zero();
  // CommonNormal's shift is first order in the angle phi between the normals: a
  // sphere's point phi from its lowest point lies R sin(phi) from it across the
  // plane, not R phi (11 um less at 4 mm on a 3 cm ball)
  const double phi = std::atan2(n.cross(n_q).norm(), -n.dot(n_q));
  return phi > 1e-9 ? Vec3(g.shift * (std::sin(phi) / phi)) : g.shift;
}

// control points of a tree against the analytic plane z = 0 of the plane body. With
// the common normal, a curved surface's normal force acts where it touches the plane
// (PlaneTouch; Contact::touch, or the anchors moved there between rigid surfaces):
// at its control points, a ball's support was the polygon of the points under it, and
// a soft ball left at rest on a table rocked and rolled millimetres away by itself.
void CollidePlane(int id_q, const SphereTree& tq, const Pose& pose_q, bool deforms, int id_p, const Pose& pose_p,
                  const CollisionParams& params, CollisionScratch* s, ContactBuffer* out, CollisionStats* stats) {
  const auto t0 = Clock::now();
  const Vec3 n_world = pose_p.R.col(2);
  const Vec3 n_q = pose_q.RotateInverse(n_world);
  const double offset = n_world.dot(pose_q.t - pose_p.t);  // signed distance of q's origin
  s->stack.clear();
  s->stack.push_back(PackPair(tq.root(), 0));
  int tests = 0;
  s->touched_a.clear();
  const TraversalNode* nodes = tq.traversal();
  while (!s->stack.empty()) {
    const int ni = PairFirst(s->stack.back());
    s->stack.pop_back();
    const TraversalNode& node = nodes[ni];
    ++tests;
    if (n_q.dot(node.center) + offset > node.radius + params.contact_threshold) continue;
    if (node.IsLeaf()) {
      s->touched_a.push_back(node.leaf());
    } else {
      s->stack.push_back(PackPair(node.child[1], 0));
      s->stack.push_back(PackPair(node.child[0], 0));
    }
  }
  stats->node_pairs += tests;
  stats->leaf_pairs += static_cast<int>(s->touched_a.size());
  const auto t1 = Clock::now();
  for (int lq : s->touched_a) {
    const Vec3& c = tq.control_point(lq);
    const double gap = n_q.dot(c) + offset;
    ++stats->projections;
    if (!(gap < params.contact_threshold)) continue;
    Contact ct;
    ct.body[0] = id_q;
    ct.body[1] = id_p;
    ct.leaf = lq;
    ct.surface_leaf = -1;
    ct.anchor[0] = c;
    ct.anchor[1] = pose_p.ApplyInverse(pose_q.Apply(c) - gap * n_world);
    if (params.common_normal) {
      const Vec3 shift_q = PlaneTouch(tq, lq, n_q);
      const Vec3 shift_p = pose_p.RotateInverse(pose_q.Rotate(shift_q));
      if (deforms) {
        ct.touch[0] = shift_q;
        ct.touch[1] = shift_p;
      } else {
        ct.anchor[0] += shift_q;
        ct.anchor[1] += shift_p;
      }
    }
    ct.normal = n_world;
    ct.gap = gap;
    ct.key = ContactKey(id_q, id_p, lq);
    if (out->Push(ct)) ++stats->contacts;
  }
  s->touched_a.clear();
  const auto t2 = Clock::now();
  stats->traverse_s += Seconds(t0, t1);
  stats->project_s += Seconds(t1, t2);
}

}  // namespace

// Depth first, the nearer child first, pruned by the best leaf so far.
double SphereDistanceBound(const SphereTree& ts, const Vec3& x, CollisionScratch* s) {
  double best = std::numeric_limits<double>::infinity();
  s->node_stack.clear();
  s->node_stack.push_back(ts.root());
  while (!s->node_stack.empty()) {
    const TreeNode& n = ts.node(s->node_stack.back());
    s->node_stack.pop_back();
    const double d = (x - n.center).norm() - n.rest_radius;
    if (d >= best) continue;
    if (n.IsLeaf()) {
      best = d;
      continue;
    }
    if (s->node_stack.size() + 2 > s->node_stack.capacity()) return -std::numeric_limits<double>::infinity();
    const TreeNode& c0 = ts.node(n.child[0]);
    const TreeNode& c1 = ts.node(n.child[1]);
    const bool first0 = (x - c0.center).squaredNorm() <= (x - c1.center).squaredNorm();
    s->node_stack.push_back(first0 ? n.child[1] : n.child[0]);
    s->node_stack.push_back(first0 ? n.child[0] : n.child[1]);
  }
  return best;
}

bool ProjectOntoSurface(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                        const MlsParams& mls, MlsProjection* out) {
  return ProjectOntoSurfaceFrom(positions, normals, idx, count, x, x, mls, out);
}

bool ProjectOntoSurfaceFrom(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                            const Vec3& start, const MlsParams& mls, MlsProjection* out) {
  if (count <= 0) return false;
  if (MlsProjectFrom(positions, normals, idx, count, x, start, mls, out)) return true;
  const int spent = out->iterations;
  // deep query: restart from its foot on the nearest point's tangent plane
  int nearest = idx[0];
  double best = (positions[nearest] - x).squaredNorm();
  for (int k = 1; k < count; ++k) {
    const double d2 = (positions[idx[k]] - x).squaredNorm();
    if (d2 < best) {
      best = d2;
      nearest = idx[k];
    }
  }
  const Vec3& n = normals[nearest];
  const Vec3 foot = x - (x - positions[nearest]).dot(n) * n;
  const bool ok = MlsProjectFrom(positions, normals, idx, count, x, foot, mls, out);
  out->iterations += spent;
  return ok;
}

bool WithinCoupledBorder(const SphereTree& ts, int coupled_leaf, const Vec3& foot) {
  const TreeNode& node = ts.node(ts.leaf_node(coupled_leaf));
  const double reach = node.rest_radius + ts.border();
  return (foot - node.center).squaredNorm() <= reach * reach;
}

// A start, not the limits: the lists grow (by doubling) to what the pair needs in its
// first steps and then stay. Reserving the limits (up to 32,768 and 65,536 pairs, 1.3 MB
// a pair, faulted in at once under mlockall) in the step of a pair's first traversal made
// the step in which a hand's segment first neared the object take 3 to 7 ms live.
void PairCache::ReserveStart(size_t moved_nodes) {
  reserved = true;
  pairs.reserve(std::min<size_t>(limit, kPairListStart));
  wide.pairs.reserve(std::min<size_t>(wide_limit, 2 * kPairListStart));
  next.pairs.reserve(std::min<size_t>(wide_limit, 2 * kPairListStart));
  next_stack.reserve(1024);
  next_nodes.reserve(moved_nodes);
  // a binary tree of n nodes has (n + 1) / 2 leaves, and the moved tree is the larger
  far_a.assign((moved_nodes + 1) / 2, FarMark{});
  far_b.assign((moved_nodes + 1) / 2, FarMark{});
}

size_t PairCache::StartBytes(size_t moved_nodes) {
  return 5 * kPairListStart * sizeof(std::pair<int, int>) + 1024 * sizeof(uint64_t) +
         moved_nodes * sizeof(TraversalNode) + 2 * ((moved_nodes + 1) / 2) * sizeof(FarMark);
}

void CollisionStats::Add(const CollisionStats& o) {
  node_pairs += o.node_pairs;
  leaf_pairs += o.leaf_pairs;
  projections += o.projections;
  fits += o.fits;
  far += o.far;
  remembered += o.remembered;
  feet_kept += o.feet_kept;
  rejected += o.rejected;
  on_edges += o.on_edges;
  out_of_border += o.out_of_border;
  culled += o.culled;
  contacts += o.contacts;
  dropped += o.dropped;
  cache_hits += o.cache_hits;
  cache_builds += o.cache_builds;
  cache_refills += o.cache_refills;
  slice_tests += o.slice_tests;
  traverse_s += o.traverse_s;
  project_s += o.project_s;
}

void CollisionScratch::Reserve(int max_leaves, int max_pairs) {
  stack.reserve(1024);
  pairs.reserve(max_pairs);
  if (static_cast<int>(best_a.size()) < max_leaves) {
    best_a.assign(max_leaves, -1);
    best_b.assign(max_leaves, -1);
    best_a_d2.assign(max_leaves, std::numeric_limits<double>::infinity());
    best_b_d2.assign(max_leaves, std::numeric_limits<double>::infinity());
    lift_a.assign(max_leaves, std::numeric_limits<double>::infinity());
    lift_b.assign(max_leaves, std::numeric_limits<double>::infinity());
    turned_normal.assign(max_leaves, Vec3::Zero());
  }
  touched_a.reserve(max_leaves);
  touched_b.reserve(max_leaves);
  node_stack.reserve(256);
  if (static_cast<int>(moved.capacity()) < 2 * max_leaves) moved.reserve(2 * max_leaves);
  ball.reserve(4096);
}

bool RootsOverlap(const CollisionShape& a, const Pose& pose_a, const CollisionShape& b, const Pose& pose_b,
                  double threshold) {
  if (a.is_plane && b.is_plane) return false;
  if (a.is_plane || b.is_plane) {
    const CollisionShape& q = a.is_plane ? b : a;
    const Pose& pq = a.is_plane ? pose_b : pose_a;
    const Pose& pp = a.is_plane ? pose_a : pose_b;
    const TreeNode& root = q.tree->node(q.tree->root());
    const double dist = pp.R.col(2).dot(pq.Apply(root.center) - pp.t);
    return dist <= q.tree->radius(q.tree->root()) + threshold;
  }
  const TreeNode& ra = a.tree->node(a.tree->root());
  const TreeNode& rb = b.tree->node(b.tree->root());
  const double reach = a.tree->radius(a.tree->root()) + b.tree->radius(b.tree->root()) + threshold;
  return (pose_a.Apply(ra.center) - pose_b.Apply(rb.center)).squaredNorm() <= reach * reach;
}

bool PairStaysClear(const CollisionShape& a, const Pose& pose_a, const CollisionShape& b, const Pose& pose_b,
                    const PairCache& cache, double threshold) {
  if (!cache.clear || cache.clear_threshold != threshold || a.is_plane || b.is_plane || !a.tree || !b.tree)
    return false;
  // the motion since as CollidePair measures it: the smaller tree moved into the larger one's frame
  const Pose b_in_a = pose_a.Inverse() * pose_b;
  const bool in_b = a.tree->nodes().size() <= b.tree->nodes().size();
  if (in_b != cache.in_b) return false;
  const Pose moved = in_b ? b_in_a.Inverse() : b_in_a;
  const double used = UsedMargin(moved, cache.clear_moved, cache.clear_drift_a, cache.clear_drift_b,
                                 (in_b ? *a.tree : *b.tree).center_extent(), *a.tree, *b.tree);
  return used < cache.clearance;
}

void CollidePair(int id_a, const CollisionShape& a, const Pose& pose_a, int id_b, const CollisionShape& b,
                 const Pose& pose_b, const CollisionParams& params, CollisionScratch* s, ContactBuffer* out,
                 CollisionStats* stats, PairCache* cache) {
  CollisionStats local;
  const int dropped_before = out->dropped;
  if (a.is_plane && b.is_plane) return;
  if (a.is_plane || b.is_plane) {
    if (a.is_plane)
      CollidePlane(id_b, *b.tree, pose_b, b.deforms, id_a, pose_a, params, s, out, &local);
    else
      CollidePlane(id_a, *a.tree, pose_a, a.deforms, id_b, pose_b, params, s, out, &local);
    local.dropped = out->dropped - dropped_before;
    if (stats) stats->Add(local);
    return;
  }

  // traverse both trees in a's frame
  const auto t0 = Clock::now();
  const Pose b_in_a = pose_a.Inverse() * pose_b;
  const Pose a_in_b = b_in_a.Inverse();
  // the smaller tree is moved into the larger one's frame, once
  const bool in_b = a.tree->nodes().size() <= b.tree->nodes().size();
  const Pose& moved_pose = in_b ? a_in_b : b_in_a;
  MoveNodes(in_b ? *a.tree : *b.tree, moved_pose, &s->moved);
  const TraversalNode* na = in_b ? s->moved.data() : a.tree->traversal();
  const TraversalNode* nb = in_b ? b.tree->traversal() : s->moved.data();
  const SphereTree& ta = *a.tree;
  const SphereTree& tb = *b.tree;
  const double thr = params.contact_threshold;

  // closest overlapping leaf on the other body, for every leaf of each body, and
  // how high each leaf centre stands above the other body's overlapping leaf slabs
  // from the centres' offset d (a's minus b's, in the traversal's frame): a's
  // height above b's slab is d . n_b, b's above a's is -d . n_a, each normal
  // turned into that frame (R maps a's frame to b's)
  const Mat3& R = a_in_b.R;
  // (the moved tree's leaf normal is turned once per leaf, when the leaf is first met)
  Vec3* turned = s->turned_normal.data();
  // a body that does not emit contacts only receives the other's control points
  const bool emit_a = a.emits_contacts || !b.emits_contacts;
  const bool emit_b = b.emits_contacts || !a.emits_contacts;
  std::optional<SideGather> one_pass;
  if (!(emit_a && emit_b)) {
    // one-pass: only the emitting side's leaves are gathered, against the other's
    // normals in the traversal's frame (the moved tree's turned once, all of them)
    const SphereTree& ts = emit_a ? tb : ta;
    const bool turn = emit_a != in_b;  // the surface's tree is the moved one
    const Vec3* normals = &ts.leaf_normal(0);
    if (turn) {
      for (int l = 0; l < ts.num_leaves(); ++l) turned[l] = (emit_a ? Mat3(R.transpose()) : R) * ts.leaf_normal(l);
      normals = turned;
    }
    if (emit_a)
      one_pass.emplace(true, ts, normals, &s->best_a, &s->best_a_d2, &s->lift_a, &s->touched_a);
    else
      one_pass.emplace(false, ts, normals, &s->best_b, &s->best_b_d2, &s->lift_b, &s->touched_b);
  }
  const SideGather* gather = one_pass ? &*one_pass : nullptr;
  bool gathered = false;
  double spare = -std::numeric_limits<double>::infinity();  // how far apart the pair is proven (PairCache::clear)
  if (cache && cache->limit > 0 && params.pair_cache_margin > 0.0)
    gathered = CachedLeafPairs(na, nb, ta, tb, in_b, moved_pose, params, cache, s, &local, gather, &spare);
  else
    TraverseTrees(na, ta.span_end(), ta.root(), nb, tb.span_end(), tb.root(), thr, s, &local);
  if (gather && !gathered) GatherSide(s->pairs, *gather);
  // two-pass: both sides at once
  if (emit_a && emit_b) for (const CollisionScratch::LeafPair& p : s->pairs) {
    double ha, hb;
    if (in_b) {
      if (s->best_a[p.leaf_a] < 0) turned[p.leaf_a] = R * ta.leaf_normal(p.leaf_a);
      ha = p.d.dot(tb.leaf_normal(p.leaf_b)) - tb.leaf_height(p.leaf_b);
      hb = -p.d.dot(turned[p.leaf_a]) - ta.leaf_height(p.leaf_a);
    } else {
      if (s->best_b[p.leaf_b] < 0) turned[p.leaf_b] = R.transpose() * tb.leaf_normal(p.leaf_b);
      ha = p.d.dot(turned[p.leaf_b]) - tb.leaf_height(p.leaf_b);
      hb = -p.d.dot(ta.leaf_normal(p.leaf_a)) - ta.leaf_height(p.leaf_a);
    }
    if (s->best_a[p.leaf_a] < 0) {
      s->touched_a.push_back(p.leaf_a);
      s->lift_a[p.leaf_a] = ha;
    } else {
      s->lift_a[p.leaf_a] = std::min(s->lift_a[p.leaf_a], ha);
    }
    if (s->best_b[p.leaf_b] < 0) {
      s->lift_b[p.leaf_b] = hb;
    } else {
      s->lift_b[p.leaf_b] = std::min(s->lift_b[p.leaf_b], hb);
    }
    if (p.dist2 < s->best_a_d2[p.leaf_a] || s->best_a[p.leaf_a] < 0) {
      s->best_a[p.leaf_a] = p.leaf_b;
      s->best_a_d2[p.leaf_a] = p.dist2;
    }
    if (s->best_b[p.leaf_b] < 0) s->touched_b.push_back(p.leaf_b);
    if (p.dist2 < s->best_b_d2[p.leaf_b] || s->best_b[p.leaf_b] < 0) {
      s->best_b[p.leaf_b] = p.leaf_a;
      s->best_b_d2[p.leaf_b] = p.dist2;
    }
  }
  const auto t1 = Clock::now();

  // interpenetration: a's control points on b's surface, then b's on a's
  const bool rigid = !a.deforms && !b.deforms;
  const bool two_pass = emit_a && emit_b;
  ProjectSide(id_a, *a.tree, a_in_b, id_b, b, pose_b, params, emit_a, two_pass, rigid, &s->best_a, &s->best_a_d2,
              &s->lift_a, &s->touched_a, cache ? &cache->far_a : nullptr, s, out, &local, &spare);
  ProjectSide(id_b, *b.tree, b_in_a, id_a, a, pose_a, params, emit_b, two_pass, rigid, &s->best_b, &s->best_b_d2,
              &s->lift_b, &s->touched_b, cache ? &cache->far_b : nullptr, s, out, &local, &spare);
  if (cache) {
    // no contact, and every control point proven farther than the threshold by `spare`
    cache->clear = params.skip_clear_pairs && params.max_bandwidth_factor <= 1.0 && local.contacts == 0 &&
                   out->dropped == dropped_before && spare > 0.0;
    if (cache->clear) {
      cache->clearance = spare;
      cache->clear_threshold = params.contact_threshold;
      cache->clear_moved = moved_pose;
      cache->clear_drift_a = ta.growth_drift();
      cache->clear_drift_b = tb.growth_drift();
    }
  }
  const auto t2 = Clock::now();
  local.traverse_s += Seconds(t0, t1);
  local.project_s += Seconds(t1, t2);
  local.dropped = out->dropped - dropped_before;
  if (stats) stats->Add(local);
}

}  // namespace gs
