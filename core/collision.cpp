#include "core/collision.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace gs {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// collects the overlapping leaf pairs of two trees; b_in_a maps b's frame to a's
void TraverseTrees(const SphereTree& ta, const SphereTree& tb, const Pose& b_in_a, double threshold,
                   CollisionScratch* s, CollisionStats* stats) {
  const TraversalNode* na_ = ta.traversal();
  const TraversalNode* nb_ = tb.traversal();
  s->stack.clear();
  s->pairs.clear();
  s->stack.emplace_back(ta.root(), tb.root());
  int tests = 0;
  while (!s->stack.empty()) {
    const auto [ia, ib] = s->stack.back();
    s->stack.pop_back();
    const TraversalNode& a = na_[ia];
    const TraversalNode& b = nb_[ib];
    const Vec3 cb = b_in_a.R * b.center + b_in_a.t;
    const double reach = a.radius + b.radius + threshold;
    const double d2 = (cb - a.center).squaredNorm();
    ++tests;
    if (d2 > reach * reach) continue;
    const bool a_leaf = a.IsLeaf(), b_leaf = b.IsLeaf();
    if (a_leaf && b_leaf) {
      s->pairs.push_back({a.leaf(), b.leaf(), d2});
    } else if (b_leaf || (!a_leaf && a.radius >= b.radius)) {
      // descend the larger node
      s->stack.emplace_back(a.child[1], ib);
      s->stack.emplace_back(a.child[0], ib);
    } else {
      s->stack.emplace_back(ia, b.child[1]);
      s->stack.emplace_back(ia, b.child[0]);
    }
  }
  stats->node_pairs += tests;
  stats->leaf_pairs += static_cast<int>(s->pairs.size());
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

// projects the control points of the query body onto the surface body's MLS surface
// for every query leaf that has a coupled leaf in best[]; consumes `touched`
void ProjectSide(int id_q, const SphereTree& tq, const Pose& q_to_s, int id_s, const CollisionShape& surf,
                 const Pose& pose_s, const CollisionParams& params, bool emit, std::vector<int>* best,
                 std::vector<double>* best_d2, std::vector<double>* lift, std::vector<int>* touched,
                 ContactBuffer* out, CollisionStats* stats) {
  const SphereTree& ts = *surf.tree;
  const Vec3* pos = surf.cloud->positions.data();
  const Vec3* nrm = surf.cloud->normals.data();
  const double h = surf.mls.bandwidth;
  MlsParams mls = surf.mls;
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
      continue;
    }
    // bandwidth from the distance between the coupled centres, clamped to the body's range
    mls.bandwidth = std::clamp(std::sqrt(d2), h, params.max_bandwidth_factor * h);
    const Vec3 x = q_to_s.Apply(tq.control_point(lq));
    int count = 0;
    const int* idx = ts.neighbourhood(ls, &count);
    MlsProjection proj;
    ++stats->projections;
    if (!ProjectOntoSurface(pos, nrm, idx, count, x, mls, &proj) || !proj.point.allFinite() ||
        !proj.normal.allFinite()) {
      ++stats->rejected;
      continue;
    }
    // landed outside the coupled leaf (deep or at a sharp edge): once more with the leaf
    // nearest to where it landed, whose neighbourhood holds every point the kernel reaches
    int coupled = ls;
    {
      const TreeNode& first = ts.node(ts.leaf_node(ls));
      if ((proj.point - first.center).squaredNorm() > first.rest_radius * first.rest_radius) {
        const int near = NearestLeaf(ts, proj.point);
        MlsProjection again;
        int n2 = 0;
        const int* idx2 = ts.neighbourhood(near, &n2);
        if (near != ls && ProjectOntoSurface(pos, nrm, idx2, n2, x, mls, &again) && again.point.allFinite() &&
            again.normal.allFinite()) {
          proj = again;
          coupled = near;
        }
      }
    }
    // a projection outside the coupled node's border is a curvature artefact
    const TreeNode& node = ts.node(ts.leaf_node(coupled));
    const double reach = node.rest_radius + ts.border();
    if ((proj.point - node.center).squaredNorm() > reach * reach) {
      ++stats->rejected;
      continue;
    }
    const double gap = (x - proj.point).dot(proj.normal);  // eq. 4: negative inside
    if (!(gap < params.contact_threshold)) continue;
    Contact c;
    c.body[0] = id_q;
    c.body[1] = id_s;
    c.leaf = lq;
    c.surface_leaf = coupled;
    c.anchor[0] = tq.control_point(lq);
    c.anchor[1] = proj.point;
    c.normal = pose_s.Rotate(proj.normal);
    c.gap = gap;
    c.key = ContactKey(id_q, id_s, lq);
    if (out->Push(c)) ++stats->contacts;
  }
  touched->clear();
}

// control points of a tree against the analytic plane z = 0 of the plane body
void CollidePlane(int id_q, const SphereTree& tq, const Pose& pose_q, int id_p, const Pose& pose_p,
                  const CollisionParams& params, CollisionScratch* s, ContactBuffer* out, CollisionStats* stats) {
  const auto t0 = Clock::now();
  const Vec3 n_world = pose_p.R.col(2);
  const Vec3 n_q = pose_q.RotateInverse(n_world);
  const double offset = n_world.dot(pose_q.t - pose_p.t);  // signed distance of q's origin
  s->stack.clear();
  s->stack.emplace_back(tq.root(), 0);
  int tests = 0;
  s->touched_a.clear();
  while (!s->stack.empty()) {
    const int ni = s->stack.back().first;
    s->stack.pop_back();
    const TreeNode& node = tq.node(ni);
    ++tests;
    if (n_q.dot(node.center) + offset > node.radius + params.contact_threshold) continue;
    if (node.IsLeaf()) {
      s->touched_a.push_back(node.leaf);
    } else {
      s->stack.emplace_back(node.child[1], 0);
      s->stack.emplace_back(node.child[0], 0);
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

bool ProjectOntoSurface(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                        const MlsParams& mls, MlsProjection* out) {
  if (count <= 0) return false;
  if (MlsProject(positions, normals, idx, count, x, mls, out)) return true;
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
  return MlsProject(positions, normals, idx, count, foot, mls, out);
}

void CollisionStats::Add(const CollisionStats& o) {
  node_pairs += o.node_pairs;
  leaf_pairs += o.leaf_pairs;
  projections += o.projections;
  rejected += o.rejected;
  culled += o.culled;
  contacts += o.contacts;
  dropped += o.dropped;
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
  }
  touched_a.reserve(max_leaves);
  touched_b.reserve(max_leaves);
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
    return dist <= root.radius + threshold;
  }
  const TreeNode& ra = a.tree->node(a.tree->root());
  const TreeNode& rb = b.tree->node(b.tree->root());
  const double reach = ra.radius + rb.radius + threshold;
  return (pose_a.Apply(ra.center) - pose_b.Apply(rb.center)).squaredNorm() <= reach * reach;
}

void CollidePair(int id_a, const CollisionShape& a, const Pose& pose_a, int id_b, const CollisionShape& b,
                 const Pose& pose_b, const CollisionParams& params, CollisionScratch* s, ContactBuffer* out,
                 CollisionStats* stats) {
  CollisionStats local;
  const int dropped_before = out->dropped;
  if (a.is_plane && b.is_plane) return;
  if (a.is_plane || b.is_plane) {
    if (a.is_plane)
      CollidePlane(id_b, *b.tree, pose_b, id_a, pose_a, params, s, out, &local);
    else
      CollidePlane(id_a, *a.tree, pose_a, id_b, pose_b, params, s, out, &local);
    local.dropped = out->dropped - dropped_before;
    if (stats) stats->Add(local);
    return;
  }

  // traverse both trees in a's frame
  const auto t0 = Clock::now();
  const Pose b_in_a = pose_a.Inverse() * pose_b;
  const Pose a_in_b = b_in_a.Inverse();
  TraverseTrees(*a.tree, *b.tree, b_in_a, params.contact_threshold, s, &local);

  // closest overlapping leaf on the other body, for every leaf of each body, and
  // how high each leaf centre stands above the other body's overlapping leaf slabs
  const SphereTree& ta = *a.tree;
  const SphereTree& tb = *b.tree;
  for (const CollisionScratch::LeafPair& p : s->pairs) {
    const Vec3 ca = ta.control_point(p.leaf_a), cb = tb.control_point(p.leaf_b);
    const double ha = (a_in_b.Apply(ca) - cb).dot(tb.leaf_normal(p.leaf_b)) - tb.leaf_height(p.leaf_b);
    const double hb = (b_in_a.Apply(cb) - ca).dot(ta.leaf_normal(p.leaf_a)) - ta.leaf_height(p.leaf_a);
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
  // (a body that does not emit contacts only receives the other's control points)
  const bool emit_a = a.emits_contacts || !b.emits_contacts;
  const bool emit_b = b.emits_contacts || !a.emits_contacts;
  ProjectSide(id_a, *a.tree, a_in_b, id_b, b, pose_b, params, emit_a, &s->best_a, &s->best_a_d2, &s->lift_a,
              &s->touched_a, out, &local);
  ProjectSide(id_b, *b.tree, b_in_a, id_a, a, pose_a, params, emit_b, &s->best_b, &s->best_b_d2, &s->lift_b,
              &s->touched_b, out, &local);
  const auto t2 = Clock::now();
  local.traverse_s += Seconds(t0, t1);
  local.project_s += Seconds(t1, t2);
  local.dropped = out->dropped - dropped_before;
  if (stats) stats->Add(local);
}

}  // namespace gs
