// Collision detection between two point-based bodies (paper section 3.3).
//
// 1. Traverse: the two sphere trees are descended simultaneously (the larger
//    node first) and every pair of overlapping leaves is collected. A body given
//    as an analytic plane is traversed against the half-space instead.
// 2. Interpenetration: for every leaf of one body that overlaps the other body,
//    its centre (a control point) is projected onto the other body's MLS surface,
//    built from the points of the closest overlapping leaf plus its r_eps border.
//    A projection that leaves that border is rejected (curvature artefacts).
//    The gap is (p - p_proj) . n(p_proj): negative means inside (eq. 4). Pairs
//    with gap < delta_eps enter the contact space. Both directions are done:
//    A's control points against B's surface, and B's against A's.
//
// Gaps are measured on the undeformed surfaces posed rigidly; deformation
// enters the contact space through the control-point displacements (eq. 6-7).
//
// Contacts carry a stable key (body ids, direction and leaf id) so that the
// solver can warm start from the previous step. Nothing here allocates once
// the scratch and the contact buffer have their capacity.
#pragma once

#include "core/mls.h"
#include "core/sphere_tree.h"
#include "core/types.h"

namespace gs {

/// What collision detection needs of a body's geometry.
struct CollisionShape {
  const PointCloud* cloud = nullptr;  ///< rest-frame points (null for a plane)
  const SphereTree* tree = nullptr;   ///< rest-frame tree (null for a plane)
  MlsParams mls;                      ///< projection onto this body's surface
  bool is_plane = false;              ///< analytic plane z = 0 of the body frame, normal +z
  bool emits_contacts = true;         ///< false: only the other body's control points are projected onto this one
  bool deforms = false;               ///< the body's surface deforms (its contacts act at their sample points)
};

struct CollisionParams {
  double contact_threshold = 2e-4;  ///< delta_eps (m): pairs with a larger gap are not contacts
  double max_bandwidth_factor = 1.0;  ///< projection bandwidth = clamp(centre distance, h, factor * h)
  /// true: a contact's normal is the two surfaces' common normal, from the foot's
  /// normal, the query point's own and both surfaces' curvatures (CommonNormal in
  /// collision.cpp); false: the foot's normal (tilted where the query point is off
  /// the touching point: a flat wall's points on a fingertip act as ledges).
  bool common_normal = true;
  /// true: a projection whose foot leaves the coupled leaf's radius plus r_eps
  /// border is rejected (the paper's curvature rejection); false: kept (for
  /// measuring what the rule does).
  bool curvature_rejection = true;
  /// Two-pass contact (both bodies of a pair emit): a point of a flat face of one
  /// surface (its leaf's patch trusted, its normals within 3 degrees) is not
  /// projected onto the other where that surface's MLS is shaped by a sharp edge
  /// (the foot's leaf's patch untrusted): there the quadric overshoots the face (a
  /// lip up to 0.09 spacing below it) or rounds the edge, and the edge's own points,
  /// projected onto the flat face, carry that contact in the other pass. Curved
  /// query points (a fingertip on a box's edge) keep theirs. false: kept (for
  /// measuring the rule).
  bool edge_rule = true;
  /// true: a projection stops as soon as the query point is known to stand outside
  /// the surface by more than contact_threshold (from the leaf's fit and its error
  /// before any MLS fit, or from the fits' last move), since it gives no contact
  /// (CollisionStats::far); false: every projection runs to convergence (for
  /// checking that the early stop loses no contact).
  bool far_stop = true;
  /// true: with a PairCache, a control point whose projection found it outside the
  /// surface by more than contact_threshold keeps that margin (PairCache::FarMark);
  /// while it stays coupled to the same leaf and has moved, relative to the surface,
  /// less than the margin beyond the threshold, it gives no contact and is not
  /// projected again (CollisionStats::remembered). Gaps are measured on the rest
  /// surfaces posed rigidly, so the margin holds for as long as the motion allows.
  /// false: every such point is projected every step (for checking the memory).
  bool far_memory = true;
  /// true: with a PairCache, a control point whose projection converged keeps its
  /// foot and the foot's normal (PairCache::FarMark). While it stays coupled to the
  /// same leaf and within what a converged foot may be off (MlsParams::tolerance x h
  /// x the fits' contraction, 1/20) of where it was projected, the kept foot serves
  /// and its gap is measured anew (CollisionStats::feet_kept); a point that moved
  /// farther is projected again, from its kept foot where the leaf has no trusted
  /// patch (one fit instead of two in a hold). false: every point is projected from
  /// the start a projection takes without memory (for measuring what it changes).
  bool foot_memory = true;
  /// Leaf-pair cache (PairCache): the margin, as a fraction of the two trees' mean
  /// leaf radii, by which the cached traversal reaches beyond the contact threshold.
  /// The cache serves the following steps while the trees' relative motion plus
  /// their radius growth stays within it (then refilled from the wide list). 0: every
  /// step traverses the trees. A wider margin tests more pairs every step: at 0.25
  /// the held whole hand at the paper's densities tested 32,775 for 19,825 overlapping.
  double pair_cache_margin = 0.1;
  /// The cache's wide list: the leaf pairs within this margin (the same fraction,
  /// larger than pair_cache_margin) beyond the threshold. When the served list's
  /// margin is used up, the list is refilled by testing the wide list's pairs
  /// instead of descending the trees, and the next wide list is traversed ahead of
  /// need, a slice of pair_cache_slice_tests sphere tests per step: no step pays a
  /// whole traversal while the motion stays within it. The slices are sized to end
  /// the next list when half the wide list's remaining margin is used, at the pace
  /// of the motion so far (at least pair_cache_slice_tests sphere tests a step).
  /// 0: no wide list (every refill descends the trees).
  double pair_cache_wide_margin = 1.0;
  int pair_cache_slice_tests = 512;
  /// A pair whose last detection found no contact and proved its control points
  /// apart by more than the motion since is not detected (PairCache::clear): its
  /// result would be no contact. false: detected in every step.
  bool skip_clear_pairs = true;
};

/// One contact: control point `leaf` of body[0] against the surface of body[1].
struct Contact {
  int body[2] = {-1, -1};
  int leaf = -1;           ///< control point of body[0]
  int surface_leaf = -1;   ///< coupled leaf of body[1] (-1 against a plane)
  Vec3 anchor[2];          ///< contact point in each body's rest frame (m)
  /// Rest-frame offset from anchor[s] to where the two rest surfaces touch. A pair
  /// with a deforming side keeps its anchors at the sample point (its eq. 8 weights
  /// and friction act there) and its normal force turns the bodies about this point
  /// (contact_space.cpp); between rigid surfaces the anchors are moved there instead.
  Vec3 touch[2] = {Vec3::Zero(), Vec3::Zero()};
  Vec3 normal;             ///< world frame, unit, from body[1] toward body[0]
  double gap = 0.0;        ///< signed distance (m), negative when interpenetrating
  uint64_t key = 0;        ///< stable id for warm starting
};

inline uint64_t ContactKey(int body0, int body1, int leaf) {
  return (static_cast<uint64_t>(body0 & 0xffff) << 48) | (static_cast<uint64_t>(body1 & 0xffff) << 32) |
         static_cast<uint64_t>(static_cast<uint32_t>(leaf));
}

struct CollisionStats {
  int node_pairs = 0;     ///< sphere-sphere tests during traversal
  int leaf_pairs = 0;     ///< overlapping leaf pairs found
  int projections = 0;    ///< MLS projections done
  int fits = 0;           ///< MLS fits (projection iterations) done
  int rejected = 0;       ///< projections rejected (left the border, failed, or a sideways deep foot)
  int out_of_border = 0;  ///< of rejected: feet outside the coupled leaf's radius + r_eps (curvature rejection)
  int on_edges = 0;       ///< of rejected: smooth points on an edge's MLS, left to the edge's own points (edge_rule)
  int culled = 0;         ///< leaves skipped: above every overlapping leaf's slab by more than delta_eps
  int far = 0;            ///< projections stopped early: outside the surface by more than delta_eps
  int remembered = 0;     ///< control points not projected: an earlier step's projection found them outside by more than they moved since (far_memory)
  int feet_kept = 0;      ///< control points not projected: they keep the foot of an earlier step's projection (foot_memory)
  int contacts = 0;       ///< contacts added
  int dropped = 0;        ///< contacts lost because the buffer was full
  int cache_hits = 0;     ///< body pairs whose leaf pairs came from their PairCache
  int cache_builds = 0;   ///< body pairs whose PairCache was (re)built by a whole traversal in the step
  int cache_refills = 0;  ///< body pairs whose served list was refilled from the wide list (no descent)
  int slice_tests = 0;    ///< of node_pairs, the tests spent on slices of the next wide lists
  double traverse_s = 0;  ///< time in traversal (s)
  double project_s = 0;   ///< time in projections (s)
  void Add(const CollisionStats& o);
};

/// Reusable buffers (sized by Reserve; never grown inside Collide when large enough).
struct CollisionScratch {
  struct LeafPair {
    int leaf_a, leaf_b;
    double dist2;  // squared distance between the two leaf centres
    Vec3 d;        // centre of a minus centre of b, in the frame of the traversal
  };
  /// node pairs (a << 32 | b) still to descend: one 8-byte word written and read back
  /// whole (a pair of ints stored apart and read as one stalls on store forwarding)
  std::vector<uint64_t> stack;
  std::vector<LeafPair> pairs;
  std::vector<int> best_a, best_b;       // per leaf: best coupled leaf on the other body, -1 when none
  std::vector<double> best_a_d2, best_b_d2;
  std::vector<double> lift_a, lift_b;    // per leaf: lowest height above the other body's overlapping leaf slabs
  std::vector<Vec3> turned_normal;       // per leaf of the tree moved for traversal: its normal in the other's frame
  std::vector<int> touched_a, touched_b;
  std::vector<TraversalNode> moved;      // the smaller tree's nodes in the other body's frame
  std::vector<int> node_stack, ball;     // gathering the points around a query off the surface
  void Reserve(int max_leaves, int max_pairs);
};

/// The leaf pairs of two trees found by a traversal that reached `margin` beyond
/// the contact threshold, kept for the following steps. While the moved tree's
/// pose relative to the other has carried no node centre farther than the margin
/// less both trees' radius growth since (SphereTree::growth_drift), every leaf pair
/// a fresh traversal would find is in the list: a step then tests the listed pairs
/// against the current centres and radii instead of descending the trees. A pair
/// the list keeps may pass that test where a fresh traversal would have stopped at
/// an ancestor (node spheres bound the points, not their children's spheres): it
/// only adds a candidate.
struct PairList {
  std::vector<std::pair<int, int>> pairs;  ///< the leaf pairs as (node of a, node of b): no leaf-to-node lookup when served
  Pose moved;            ///< the moved tree's pose in the other tree's frame when built
  double margin = 0.0;   ///< m
  double drift_a = 0.0, drift_b = 0.0;  ///< the trees' growth_drift() when built
  bool valid = false;
};

/// The leaf-pair cache of two trees: a served list (CollisionParams::pair_cache_margin)
/// tested every step, and a wide list (pair_cache_wide_margin) it is refilled from
/// while the wide list still covers the served list's margin. The next wide list is
/// traversed in slices ahead of need, from the pose at which it began (its moved
/// nodes are kept; the other tree's radii are read as they grow, which only widens
/// the list), and replaces the wide list when done. Every slice is counted in
/// sphere tests, never in time, so a step's contacts do not depend on the machine.
/// The lists' capacities (`limit` and `wide_limit` pairs) are taken the first time
/// the pair is traversed, once; a list that would outgrow its capacity is not kept.
struct PairCache {
  std::vector<std::pair<int, int>> pairs;  ///< the served list (see PairList)
  size_t limit = 0;      ///< most pairs served (0: no cache for this pair)
  Pose moved;
  bool in_b = false;     ///< a's tree was the moved one (for every list)
  bool valid = false;
  double margin = 0.0;
  double drift_a = 0.0, drift_b = 0.0;
  size_t wide_limit = 0;  ///< most pairs in a wide list (0: none)
  PairList wide;          ///< what the served list is refilled from
  PairList next;          ///< the next wide list, while it is traversed
  bool building = false;  ///< `next` is being traversed
  int wide_age = 0;       ///< steps since the wide list's pose was taken
  int next_age = 0;       ///< steps since the next list's pose was taken
  int wide_tests = 0;     ///< sphere tests of the last whole wide traversal (what the next will take, roughly)
  int next_tests = 0;     ///< sphere tests spent on `next` so far
  double wide_used = 0.0; ///< the wide list's margin used as of the last step (m; < 0: not yet seen)
  std::vector<uint64_t> next_stack;        ///< its traversal's node pairs still to descend
  std::vector<TraversalNode> next_nodes;   ///< the moved tree's nodes when it began
  /// What the last projection of a control point proved: standing at x (the
  /// surface body's rest frame), coupled to the surface's leaf `coupled`, it was
  /// outside the surface by at least `outside` (m; far_memory) and, when it
  /// converged, its foot on the surface was `foot` with normal `normal`, ending in
  /// the surface's leaf `foot_leaf` (foot_memory; < 0: no foot). Per leaf of a (on
  /// b) and of b (on a); coupled < 0: nothing known.
  struct FarMark {
    Vec3 x = Vec3::Zero();
    double outside = 0.0;
    int coupled = -1;
    int foot_leaf = -1;
    Vec3 foot = Vec3::Zero();
    Vec3 normal = Vec3::Zero();
  };
  std::vector<FarMark> far_a, far_b;
  /// The last detection found no contact and proved every control point that could
  /// make one farther from the other surface than the threshold by `clearance` (m):
  /// the sphere gaps of the served list's other pairs, the slabs, far stops, far
  /// memories and gaps of the rest. While the motion since (`clear_moved`, the
  /// trees' growth then) stays below it the pair has no contact (PairStaysClear).
  bool clear = false;
  double clearance = 0.0;
  double clear_threshold = 0.0;  ///< the contact threshold it was proven for
  Pose clear_moved;
  double clear_drift_a = 0.0, clear_drift_b = 0.0;
  bool reserved = false;  ///< the lists have their first capacity (they grow from it as the pair needs)
  /// Gives the lists their first capacity (moved_nodes: the larger tree's node count).
  void ReserveStart(size_t moved_nodes);
  /// The bytes ReserveStart takes.
  static size_t StartBytes(size_t moved_nodes);
  void Invalidate() {
    valid = false;
    wide.valid = false;
    building = false;
    clear = false;
  }
};

/// A fixed-capacity contact list: adding beyond capacity drops and counts.
struct ContactBuffer {
  std::vector<Contact> items;
  int capacity = 0;
  int dropped = 0;
  void Reserve(int n) {
    items.reserve(n);
    capacity = n;
  }
  void Clear() {
    items.clear();
    dropped = 0;
  }
  bool Push(const Contact& c) {
    if (static_cast<int>(items.size()) >= capacity) {
      ++dropped;
      return false;
    }
    items.push_back(c);
    return true;
  }
};

/// Projects x onto the MLS surface of the points idx[0..count). When x is deeper
/// than the kernel's support (no point carries weight there), the projection
/// starts from x's foot on the tangent plane of the nearest point instead, so
/// that deep interpenetration still yields a gap.
bool ProjectOntoSurface(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                        const MlsParams& mls, MlsProjection* out);
/// The same, with the fits starting at `start` (near x's foot on the surface).
bool ProjectOntoSurfaceFrom(const Vec3* positions, const Vec3* normals, const int* idx, int count, const Vec3& x,
                            const Vec3& start, const MlsParams& mls, MlsProjection* out);

/// The paper's curvature rejection: true when a projection's foot (surface body's
/// rest frame) lies within the radius plus r_eps border of the leaf the traversal
/// coupled to the query, wherever the projection went on to end.
bool WithinCoupledBorder(const SphereTree& ts, int coupled_leaf, const Vec3& foot);

/// Appends the contacts between bodies a and b (ids id_a, id_b) to `out`.
/// With `cache` (two trees; ignored for a plane), the traversal is served from it
/// or rebuilds it (params.pair_cache_margin).
void CollidePair(int id_a, const CollisionShape& a, const Pose& pose_a, int id_b, const CollisionShape& b,
                 const Pose& pose_b, const CollisionParams& params, CollisionScratch* scratch, ContactBuffer* out,
                 CollisionStats* stats, PairCache* cache = nullptr);

/// A lower bound on the distance from x (the tree's rest frame) to the surface the
/// tree covers: the distance to its nearest leaf sphere (each leaf's points plus the
/// coverage margin, which the traversal's pairing rests on), negative inside one;
/// -inf when the scratch's stack would have to grow. ProjectSide proves a point apart
/// by it where its projection proves nothing (failed or rejected).
double SphereDistanceBound(const SphereTree& ts, const Vec3& x, CollisionScratch* s);

/// True when the pair's last detection (CollidePair with `cache`) proved it apart
/// by more than the bodies have moved since: it has no contact now, exactly, and
/// need not be detected (CollisionParams::skip_clear_pairs).
bool PairStaysClear(const CollisionShape& a, const Pose& pose_a, const CollisionShape& b, const Pose& pose_b,
                    const PairCache& cache, double threshold);

/// True when the root spheres (plus the threshold) overlap: the broad phase.
bool RootsOverlap(const CollisionShape& a, const Pose& pose_a, const CollisionShape& b, const Pose& pose_b,
                  double threshold);

}  // namespace gs
