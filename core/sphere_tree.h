// Binary sphere tree over a body's surface points (paper section 3.3), built
// once in the body's rest frame.
//
// - Every node bounds the points below it (plus a coverage margin, so that the
//   continuous MLS surface between samples is enclosed too). The paper's
//   per-node level-of-detail samples are not kept: collision detection never
//   reads them (docs/collision.md).
// - There are exactly `leaf_count` leaves. A leaf's centre lies on the MLS
//   surface; the leaf centres are the body's control points (paper 3.5.1).
// - Each leaf keeps its neighbourhood: every point within its radius plus the
//   r_eps border. Collision detection projects onto the MLS surface of those
//   points only (the "coupled node plus r_eps border" of the paper).
// - Each leaf caches the MLS surface fitted at its centre as a quadratic patch;
//   a projection near the leaf starts on it, usually one fit from converged.
// - Refit after deformation is bottom-up from the leaves whose displacement
//   changed, and stops at a given depth (paper: "we stop the process when we
//   reach a given level in the hierarchy"): nodes above it are not visited;
//   their radius is the rest radius inflated by the largest growth found at the
//   stop level, which still encloses everything below.
//   Gaps are measured on the undeformed surface and deformation enters through
//   the displacements (paper eq. 6-7), so a refit sphere encloses the surface both
//   at rest and deformed: centres stay, radii grow by the displacement bound.
//
// Leaf ids are stable for the life of the tree: contacts, warm starts and
// deformation state are keyed by them.
#pragma once

#include <cmath>

#include "core/mls.h"
#include "core/types.h"

namespace gs {

struct SphereTreeParams {
  int leaf_count = 1;         ///< number of leaves = control points
  double border = 0.0;        ///< r_eps (m): neighbourhood margin around each leaf sphere
  double cover_margin = 0.0;  ///< (m) added to every radius; 0 = automatic (largest nearest-neighbour gap)
};

struct TreeNode {
  Vec3 center = Vec3::Zero();  ///< rest frame (m)
  double rest_radius = 0.0;    ///< radius of the undeformed surface (m); after refit: SphereTree::radius
  int child[2] = {-1, -1};     ///< children, -1 for a leaf
  int parent = -1;
  int depth = 0;
  int leaf = -1;               ///< leaf id (control point index) or -1
  int first = 0, count = 0;    ///< points below this node: point_order()[first .. first+count)

  bool IsLeaf() const { return child[0] < 0; }
};

/// The hot part of a node, what traversal reads: 40 bytes.
struct TraversalNode {
  Vec3 center;     ///< rest frame (m)
  double radius;   ///< current radius (m)
  int child[2];    ///< children; for a leaf child[0] = -1 and child[1] = leaf id
  bool IsLeaf() const { return child[0] < 0; }
  int leaf() const { return child[1]; }
};
static_assert(sizeof(TraversalNode) == 40, "traversal nodes stay compact");

struct RefitStats {
  int nodes_visited = 0;   ///< nodes whose sphere was recomputed or inflated
  int leaves_changed = 0;
};

class SphereTree {
 public:
  enum class EBuildError { None, TooFewPoints, BadLeafCount, NotFinite };

  /// Builds the tree over `cloud` (rest frame). `mls` projects leaf centres onto the surface.
  EBuildError Build(const PointCloud& cloud, const MlsParams& mls, const SphereTreeParams& params);

  const std::vector<TreeNode>& nodes() const { return nodes_; }
  const TreeNode& node(int i) const { return nodes_[i]; }
  /// Compact copies of the nodes (same indices) for traversal.
  const TraversalNode* traversal() const { return hot_.data(); }
  /// Nodes are in depth-first order, left child first: node i's subtree is the
  /// index range [i, span_end()[i]).
  const int* span_end() const { return span_end_.data(); }
  int root() const { return 0; }
  int num_leaves() const { return static_cast<int>(leaf_node_.size()); }
  int leaf_node(int leaf) const { return leaf_node_[leaf]; }
  int depth() const { return max_depth_; }
  /// Rest position of control point `leaf` (the leaf centre, on the MLS surface).
  const Vec3& control_point(int leaf) const { return control_points_[leaf]; }
  const std::vector<Vec3>& control_points() const { return control_points_; }
  /// Permutation of point indices; each node covers a contiguous range of it.
  const std::vector<int>& point_order() const { return point_order_; }
  /// Leaf owning each point.
  const std::vector<int>& point_leaf() const { return point_leaf_; }
  /// Points within the leaf's radius + border (indices into the cloud).
  const int* neighbourhood(int leaf, int* count) const {
    *count = nbr_start_[leaf + 1] - nbr_start_[leaf];
    return nbr_items_.data() + nbr_start_[leaf];
  }
  /// Mean outward normal of a leaf's points (unit, rest frame).
  const Vec3& leaf_normal(int leaf) const { return leaf_normal_[leaf]; }
  /// Cosine of the widest angle between a leaf's point normals and its mean
  /// normal: 1 on a flat face, lower where the leaf bends or straddles an edge.
  double leaf_flatness(int leaf) const { return leaf_min_cos_[leaf]; }
  /// Height of the leaf's surface above its centre along leaf_normal (m, >= 0),
  /// including the refit growth: no surface point of the leaf lies higher.
  double leaf_height(int leaf) const { return leaf_top_[leaf]; }
  /// The MLS surface fitted at a leaf's centre (rest frame), or null when that
  /// fit failed: a first guess for projections onto the surface near the leaf.
  const MlsPatch* leaf_patch(int leaf) const { return patch_ok_[leaf] ? &patches_[leaf] : nullptr; }
  /// Largest distance between a trusted leaf patch and the MLS surface over the
  /// leaf (measured at build at the leaf's points; infinite when not trusted).
  double leaf_patch_error(int leaf) const { return patch_error_[leaf]; }
  /// The fit at a leaf's centre whether trusted or not (null when it failed), and the
  /// largest distance between it and the MLS surface over the leaf, measured as for
  /// leaf_patch_error (infinite when a projection failed): a bound on how far x's
  /// distance to the surface there can be from its distance to the fit.
  const MlsPatch* leaf_fit(int leaf) const { return std::isfinite(fit_error_[leaf]) ? &patches_[leaf] : nullptr; }
  double leaf_fit_error(int leaf) const { return fit_error_[leaf]; }
  double border() const { return border_; }
  double cover_margin() const { return cover_margin_; }

  /// Refits after deformation. `displacement[leaf]` is the current displacement of
  /// each control point (rest frame, m), `changed[leaf]` != 0 for the leaves whose
  /// displacement changed since the last refit (only those and their ancestors are
  /// touched), `spread[leaf]` bounds how far any surface point of the leaf moved
  /// relative to the control point (m). Nodes shallower than `stop_level` are not
  /// recomputed: their radius is inflated by the largest growth below them.
  void Refit(const Vec3* displacement, const double* spread, const uint8_t* changed, int stop_level,
             RefitStats* stats);
  /// Back to the rest shape.
  void ResetRefit();
  /// Radius of node i as refit (rest radius plus growth), what traversal must use.
  /// Current radius of node i (m): its rest radius plus what refit grew it by.
  double radius(int i) const { return hot_[i].radius; }
  /// Sum over all refits of the largest rise of a leaf's growth: no node's radius
  /// has grown by more than the difference of two readings since the first one
  /// (a radius grows only through its leaves; shrinking is not subtracted).
  double growth_drift() const { return growth_drift_; }
  /// Largest distance of a node centre from the rest frame's origin (m).
  double center_extent() const { return center_extent_; }
  /// Mean rest radius of the leaves (m).
  double mean_leaf_radius() const { return mean_leaf_radius_; }

 private:
  int BuildNode(const PointCloud& cloud, int first, int count, int leaves, int parent, int depth);
  void SplitAtGap(const PointCloud& cloud, int first, int count, int leaves, const Vec3& axis, int* split,
                  int* left_leaves) const;

  // node i grown by g over its rest radius: its radius (kept in the hot node, what
  // traversal reads) and, for a leaf, its height with the growth (leaf_height)
  void SetGrowth(int i, double g) {
    growth_[i] = g;
    TraversalNode& hot = hot_[i];
    hot.radius = rest_radius_[i] + g;
    if (hot.IsLeaf()) leaf_top_[hot.leaf()] = leaf_height_[hot.leaf()] + (hot.radius - rest_radius_[i]);
  }
  std::vector<TreeNode> nodes_;
  std::vector<TraversalNode> hot_;
  std::vector<int> span_end_;
  std::vector<int> leaf_node_;
  std::vector<Vec3> control_points_;
  std::vector<int> point_order_;
  std::vector<int> point_leaf_;
  std::vector<int> nbr_start_, nbr_items_;
  std::vector<Vec3> leaf_normal_;
  std::vector<double> leaf_height_;
  std::vector<double> leaf_top_;    // leaf_height_ plus the leaf's growth (kept by SetGrowth)
  std::vector<double> leaf_min_cos_;
  std::vector<MlsPatch> patches_;
  std::vector<uint8_t> patch_ok_;
  std::vector<double> patch_error_;
  std::vector<double> fit_error_;
  std::vector<double> growth_;      // radius growth of each node over its rest radius (m)
  // per node, what refit reads (copies of the tree nodes' fields, compact)
  std::vector<double> rest_radius_;
  std::vector<int> parent_, depth_;
  std::vector<int> dirty_;          // scratch for Refit
  std::vector<uint8_t> dirty_mark_;
  std::vector<int> stop_nodes_;     // nodes at the stop level (or leaves above it)
  std::vector<int> shallow_nodes_;  // inner nodes above the stop level (inflated by top_growth_)
  int stop_level_ = -1;
  double top_growth_ = 0.0;         // growth applied to every node above the stop level
  double growth_drift_ = 0.0;
  double center_extent_ = 0.0;
  double mean_leaf_radius_ = 0.0;
  double border_ = 0.0;
  double cover_margin_ = 0.0;
  int max_depth_ = 0;
};

}  // namespace gs
