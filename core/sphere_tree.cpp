#include "core/sphere_tree.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <functional>
#include <cmath>
#include <limits>

#include "core/point_grid.h"

namespace gs {
namespace {

// spacing estimate from the bounding box surface area, for grid cell sizes
double GuessSpacing(const PointCloud& cloud) {
  Vec3 lo = cloud.positions[0], hi = cloud.positions[0];
  for (const Vec3& p : cloud.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec3 e = hi - lo;
  const double area = 2.0 * (e.x() * e.y() + e.y() * e.z() + e.z() * e.x());
  const double s = std::sqrt(area / static_cast<double>(cloud.size()));
  return s > 0 ? s : 1e-3;
}

// largest nearest-neighbour distance over the cloud: the coverage margin
double LargestNearestGap(const PointCloud& cloud, const PointGrid& grid, double spacing) {
  std::vector<int> buf;
  double worst = 0.0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Vec3& p = cloud.positions[i];
    double best = std::numeric_limits<double>::infinity();
    for (double r = 2.0 * spacing; !std::isfinite(best) && r < 1e3 * spacing; r *= 2.0) {
      buf.clear();
      grid.Query(p, r, &buf);
      for (int j : buf) {
        if (j == static_cast<int>(i)) continue;
        const double d = (cloud.positions[j] - p).norm();
        if (d > 0.0) best = std::min(best, d);
      }
    }
    if (std::isfinite(best)) worst = std::max(worst, best);
  }
  return worst;
}

// a leaf's cached patch is trusted when its neighbourhood's normals agree with it
// within this angle (cosine of 15 degrees)
constexpr double kPatchMinCos = 0.9659;

}  // namespace

SphereTree::EBuildError SphereTree::Build(const PointCloud& cloud, const MlsParams& mls,
                                          const SphereTreeParams& params) {
  nodes_.clear();
  leaf_node_.clear();
  control_points_.clear();
  const int n = static_cast<int>(cloud.size());
  if (n < 4 || cloud.normals.size() != cloud.positions.size()) return EBuildError::TooFewPoints;
  if (params.leaf_count < 1 || params.leaf_count > n) return EBuildError::BadLeafCount;
  for (int i = 0; i < n; ++i)
    if (!cloud.positions[i].allFinite() || !cloud.normals[i].allFinite()) return EBuildError::NotFinite;

  const double spacing = GuessSpacing(cloud);
  PointGrid grid;
  grid.Build(cloud.positions, 2.0 * spacing);
  // any surface point is within the covering radius of some sample; for evenly
  // spread samples that radius is below 0.75 of the largest nearest-neighbour gap
  // (0.58 in a perfect triangular packing); the coverage tests check it
  cover_margin_ = params.cover_margin > 0 ? params.cover_margin : 0.75 * LargestNearestGap(cloud, grid, spacing);
  border_ = params.border;

  // recursive median split into exactly leaf_count leaves
  point_order_.resize(n);
  for (int i = 0; i < n; ++i) point_order_[i] = i;
  nodes_.reserve(2 * static_cast<size_t>(params.leaf_count));
  max_depth_ = 0;
  BuildNode(cloud, 0, n, params.leaf_count, -1, 0);

  // leaf centres: the centroid projected onto the MLS surface of the whole cloud
  std::vector<int> nbrs;
  const double support = mls.support * mls.bandwidth;
  point_leaf_.assign(n, -1);
  for (size_t ni = 0; ni < nodes_.size(); ++ni) {
    TreeNode& node = nodes_[ni];
    if (!node.IsLeaf()) continue;
    Vec3 centroid = Vec3::Zero();
    for (int k = node.first; k < node.first + node.count; ++k) centroid += cloud.positions[point_order_[k]];
    centroid /= node.count;
    nbrs.clear();
    grid.Query(centroid, support, &nbrs);
    std::sort(nbrs.begin(), nbrs.end());
    MlsProjection proj;
    Vec3 center;
    if (!nbrs.empty() && MlsProject(cloud.positions.data(), cloud.normals.data(), nbrs.data(),
                                    static_cast<int>(nbrs.size()), centroid, mls, &proj) &&
        proj.point.allFinite() && (proj.point - centroid).norm() < 4.0 * spacing + support) {
      center = proj.point;
    } else {
      // too few neighbours for a fit: the leaf point nearest to the centroid
      int best = point_order_[node.first];
      for (int k = node.first; k < node.first + node.count; ++k) {
        const int i = point_order_[k];
        if ((cloud.positions[i] - centroid).squaredNorm() < (cloud.positions[best] - centroid).squaredNorm()) best = i;
      }
      center = cloud.positions[best];
    }
    node.center = center;
    double r = 0.0;
    for (int k = node.first; k < node.first + node.count; ++k) {
      r = std::max(r, (cloud.positions[point_order_[k]] - center).norm());
      point_leaf_[point_order_[k]] = node.leaf;
    }
    node.rest_radius = r + cover_margin_;
  }
  // leaf slabs: mean normal and the highest point above the centre along it
  leaf_normal_.assign(leaf_node_.size(), Vec3::UnitZ());
  leaf_height_.assign(leaf_node_.size(), 0.0);
  leaf_min_cos_.assign(leaf_node_.size(), 1.0);
  for (size_t l = 0; l < leaf_node_.size(); ++l) {
    const TreeNode& node = nodes_[leaf_node_[l]];
    Vec3 nsum = Vec3::Zero();
    for (int k = node.first; k < node.first + node.count; ++k) nsum += cloud.normals[point_order_[k]];
    const Vec3 n = nsum.norm() > 1e-12 ? Vec3(nsum.normalized()) : Vec3::UnitZ();
    double h = 0.0, min_cos = 1.0;
    for (int k = node.first; k < node.first + node.count; ++k) {
      const int i = point_order_[k];
      h = std::max(h, (cloud.positions[i] - node.center).dot(n));
      min_cos = std::min(min_cos, cloud.normals[i].dot(n));
    }
    leaf_normal_[l] = n;
    leaf_min_cos_[l] = min_cos;
    // between samples the surface may rise by up to the coverage margin where the leaf
    // bends; a leaf whose normals spread past 60 degrees gets no slab (height = radius)
    leaf_height_[l] = min_cos > 0.5 ? h + 0.5 * cover_margin_ : node.rest_radius;
  }
  control_points_.resize(leaf_node_.size());
  for (size_t l = 0; l < leaf_node_.size(); ++l) control_points_[l] = nodes_[leaf_node_[l]].center;

  // neighbourhoods: points within radius + border of each leaf centre
  nbr_start_.assign(leaf_node_.size() + 1, 0);
  nbr_items_.clear();
  for (size_t l = 0; l < leaf_node_.size(); ++l) {
    const TreeNode& node = nodes_[leaf_node_[l]];
    nbrs.clear();
    grid.Query(node.center, node.rest_radius + border_, &nbrs);
    std::sort(nbrs.begin(), nbrs.end());
    nbr_items_.insert(nbr_items_.end(), nbrs.begin(), nbrs.end());
    nbr_start_[l + 1] = static_cast<int>(nbr_items_.size());
  }

  // the MLS surface at each leaf centre, from its neighbourhood
  patches_.assign(leaf_node_.size(), MlsPatch{});
  patch_ok_.assign(leaf_node_.size(), 0);
  patch_error_.assign(leaf_node_.size(), std::numeric_limits<double>::infinity());
  fit_error_.assign(leaf_node_.size(), std::numeric_limits<double>::infinity());
  for (size_t l = 0; l < leaf_node_.size(); ++l) {
    int count = 0;
    const int* idx = neighbourhood(static_cast<int>(l), &count);
    MlsPatch& patch = patches_[l];
    const bool fitted =
        MlsFitPatch(cloud.positions.data(), cloud.normals.data(), idx, count, nodes_[leaf_node_[l]].center, mls,
                    &patch) &&
        patch.origin.allFinite() && patch.normal.allFinite() &&
        std::isfinite(patch.c[0] + patch.c[1] + patch.c[2] + patch.c[3] + patch.c[4] + patch.c[5]);
    bool ok = fitted;
    // trusted only where the surface is smooth over the whole neighbourhood: every
    // point's normal within kPatchMaxDegrees of the patch's normal below it (a
    // sharp edge nearby fails this; there the foot depends on the start)
    for (int k = 0; ok && k < count; ++k)
      ok = cloud.normals[idx[k]].dot(patch.NormalBelow(cloud.positions[idx[k]])) > kPatchMinCos;
    patch_ok_[l] = ok;
    // how far the patch strays from the MLS surface over the leaf: the largest
    // distance from the MLS projection of its centre and of up to 12 of its points,
    // spread over it, to the patch; infinite when the fit or a projection fails
    double err = fitted ? 0.0 : std::numeric_limits<double>::infinity();
    const TreeNode& leaf = nodes_[leaf_node_[l]];
    const int stride = std::max(1, (leaf.count + 11) / 12);
    for (int k = leaf.first - stride; std::isfinite(err) && k < leaf.first + leaf.count; k += stride) {
      const Vec3& p = k < leaf.first ? leaf.center : cloud.positions[point_order_[k]];
      MlsProjection proj;
      if (!MlsProject(cloud.positions.data(), cloud.normals.data(), idx, count, p, mls, &proj) || !proj.converged) {
        err = std::numeric_limits<double>::infinity();
        break;
      }
      err = std::max(err, (proj.point - patch.Closest(proj.point)).norm());
    }
    patch_error_[l] = ok ? err : std::numeric_limits<double>::infinity();
    // the fit against the whole surface inside the leaf's sphere (where a foot on the
    // fit is read as near this leaf): the neighbourhood's points in it, which near an
    // edge include the other face's, far from a fit of this one
    for (int k = 0; std::isfinite(err) && k < count; ++k) {
      const Vec3& p = cloud.positions[idx[k]];
      if ((p - leaf.center).squaredNorm() > leaf.rest_radius * leaf.rest_radius) continue;
      err = std::max(err, (p - patch.Closest(p)).norm());
    }
    fit_error_[l] = err;
  }

  hot_.resize(nodes_.size());
  leaf_top_.assign(leaf_node_.size(), 0.0);
  growth_.assign(nodes_.size(), 0.0);
  rest_radius_.resize(nodes_.size());
  parent_.resize(nodes_.size());
  depth_.resize(nodes_.size());
  for (size_t i = 0; i < nodes_.size(); ++i) {
    const TreeNode& n = nodes_[i];
    hot_[i].center = n.center;
    hot_[i].child[0] = n.child[0];
    hot_[i].child[1] = n.IsLeaf() ? n.leaf : n.child[1];
    rest_radius_[i] = n.rest_radius;
    parent_[i] = n.parent;
    depth_[i] = n.depth;
    SetGrowth(static_cast<int>(i), 0.0);
  }
  // depth-first layout: a subtree is the node range [i, span_end_[i])
  span_end_.assign(nodes_.size(), 0);
  for (size_t k = nodes_.size(); k-- > 0;) {
    const TreeNode& n = nodes_[k];
    span_end_[k] = n.IsLeaf() ? static_cast<int>(k) + 1 : span_end_[n.child[1]];
  }
  growth_drift_ = 0.0;
  center_extent_ = 0.0;
  for (const TreeNode& n : nodes_) center_extent_ = std::max(center_extent_, n.center.norm());
  mean_leaf_radius_ = 0.0;
  for (int ni : leaf_node_) mean_leaf_radius_ += nodes_[ni].rest_radius;
  mean_leaf_radius_ /= static_cast<double>(std::max<size_t>(1, leaf_node_.size()));
  dirty_.clear();
  dirty_.reserve(nodes_.size());
  dirty_mark_.assign(nodes_.size(), 0);
  stop_nodes_.clear();
  stop_level_ = -1;
  top_growth_ = 0.0;
  return EBuildError::None;
}

// Two surfaces of a thin part (a slab's faces) in one node: when the points, sorted
// along the split axis, have a gap wider than a quarter of their extent and each
// side is thin along the axis (under half the gap: faces seen edge-on, not curved
// patches), the node splits there and shares its leaves by count. A split by
// count alone cuts through one face once a column of the part is narrower than it
// is thick, and leaves a leaf holding points of both faces (its normals opposite,
// its patch untrusted, a sphere spanning the part).
void SphereTree::SplitAtGap(const PointCloud& cloud, int first, int count, int leaves, const Vec3& axis, int* split,
                            int* left_leaves) const {
  const double lo = cloud.positions[point_order_[first]].dot(axis);
  const double hi = cloud.positions[point_order_[first + count - 1]].dot(axis);
  double widest = 0.0;
  int at = -1;
  for (int k = first + 1; k < first + count; ++k) {
    const double g = cloud.positions[point_order_[k]].dot(axis) - cloud.positions[point_order_[k - 1]].dot(axis);
    if (g > widest) {
      widest = g;
      at = k - first;
    }
  }
  if (at < 0 || !(widest > 0.25 * (hi - lo))) return;
  // and each side thin along the axis (a face seen edge-on), not a curved patch
  const double below = cloud.positions[point_order_[first + at - 1]].dot(axis) - lo;
  const double above = hi - cloud.positions[point_order_[first + at]].dot(axis);
  if (!(std::max(below, above) < 0.5 * widest)) return;
  const int l = std::clamp(static_cast<int>(std::llround(static_cast<double>(leaves) * at / count)), 1, leaves - 1);
  if (at < l || count - at < leaves - l) return;  // a leaf needs a point
  *split = at;
  *left_leaves = l;
}

int SphereTree::BuildNode(const PointCloud& cloud, int first, int count, int leaves, int parent, int depth) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  max_depth_ = std::max(max_depth_, depth);
  {
    TreeNode& node = nodes_[index];
    node.parent = parent;
    node.depth = depth;
    node.first = first;
    node.count = count;
  }

  // centroid, covariance and bounding radius of the points below
  Vec3 c = Vec3::Zero();
  for (int k = first; k < first + count; ++k) c += cloud.positions[point_order_[k]];
  c /= count;
  double r = 0.0;
  Mat3 cov = Mat3::Zero();
  for (int k = first; k < first + count; ++k) {
    const Vec3 d = cloud.positions[point_order_[k]] - c;
    r = std::max(r, d.norm());
    cov += d * d.transpose();
  }
  nodes_[index].center = c;
  nodes_[index].rest_radius = r + cover_margin_;

  if (leaves <= 1) {
    nodes_[index].leaf = static_cast<int>(leaf_node_.size());
    leaf_node_.push_back(index);
    return index;
  }

  // split along the principal axis so that each side gets its share of leaves
  Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
  const Vec3 axis = eig.eigenvectors().col(2);
  int left_leaves = leaves / 2;
  int split = static_cast<int>(std::llround(static_cast<double>(count) * left_leaves / leaves));
  split = std::clamp(split, left_leaves, count - (leaves - left_leaves));
  auto begin = point_order_.begin() + first;
  const auto along = [&](int a, int b) {
    const double pa = cloud.positions[a].dot(axis), pb = cloud.positions[b].dot(axis);
    return pa < pb || (pa == pb && a < b);
  };
  std::sort(begin, begin + count, along);
  SplitAtGap(cloud, first, count, leaves, axis, &split, &left_leaves);
  const int right_leaves = leaves - left_leaves;
  const int left = BuildNode(cloud, first, split, left_leaves, index, depth + 1);
  const int right = BuildNode(cloud, first + split, count - split, right_leaves, index, depth + 1);
  nodes_[index].child[0] = left;
  nodes_[index].child[1] = right;
  return index;
}

void SphereTree::Refit(const Vec3* displacement, const double* spread, const uint8_t* changed, int stop_level,
                       RefitStats* stats) {
  RefitStats local;
  if (stop_level < 0) stop_level = 0;
  if (stop_level != stop_level_) {
    // the frontier where refit stops: nodes at the stop level, or leaves above it
    stop_level_ = stop_level;
    stop_nodes_.clear();
    shallow_nodes_.clear();
    for (size_t i = 0; i < nodes_.size(); ++i) {
      if (nodes_[i].depth == stop_level || (nodes_[i].IsLeaf() && nodes_[i].depth < stop_level))
        stop_nodes_.push_back(static_cast<int>(i));
      else if (nodes_[i].depth < stop_level)
        shallow_nodes_.push_back(static_cast<int>(i));
    }
  }

  // changed leaves: growth = displacement bound of their surface
  dirty_.clear();
  double rise = 0.0;  // largest growth increase of a leaf
  for (int l = 0; l < num_leaves(); ++l) {
    if (!changed[l]) continue;
    ++local.leaves_changed;
    const int ni = leaf_node_[l];
    double g = growth_[ni];
    const double bound = displacement[l].norm() + std::max(0.0, spread[l]);
    if (std::isfinite(bound)) {
      rise = std::max(rise, bound - g);
      g = bound;
    }
    SetGrowth(ni, g);
    ++local.nodes_visited;
    for (int p = parent_[ni]; p >= 0 && depth_[p] >= stop_level && !dirty_mark_[p]; p = parent_[p]) {
      dirty_mark_[p] = 1;
      dirty_.push_back(p);
    }
  }

  // ancestors down to the stop level, children before parents: growth = max over
  // children (nodes are in depth-first order, so a child's index exceeds its parent's)
  // (in decreasing index order: sorted when few, else read off the marks, which
  // visits the same nodes in the same order without sorting thousands)
  auto inflate = [&](int ni) {
    dirty_mark_[ni] = 0;
    const TraversalNode& node = hot_[ni];
    SetGrowth(ni, std::max(growth_[node.child[0]], growth_[node.child[1]]));
    ++local.nodes_visited;
  };
  if (dirty_.size() * 32 < nodes_.size()) {
    std::sort(dirty_.begin(), dirty_.end(), std::greater<int>());
    for (int ni : dirty_) inflate(ni);
  } else {
    for (int ni = static_cast<int>(nodes_.size()) - 1; ni >= 0; --ni)
      if (dirty_mark_[ni]) inflate(ni);
  }

  // above the stop level: inflate by the largest growth on the frontier
  if (local.leaves_changed > 0 && stop_level > 0) {
    double top = 0.0;
    for (int ni : stop_nodes_) top = std::max(top, growth_[ni]);
    if (top != top_growth_) {
      top_growth_ = top;
      for (int i : shallow_nodes_) {
        SetGrowth(i, top);
        ++local.nodes_visited;
      }
    }
  }
  growth_drift_ += rise;
  if (stats) *stats = local;
}

void SphereTree::ResetRefit() {
  for (size_t i = 0; i < nodes_.size(); ++i) SetGrowth(static_cast<int>(i), 0.0);
  top_growth_ = 0.0;
}

}  // namespace gs
