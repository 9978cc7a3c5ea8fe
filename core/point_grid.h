// Uniform hash grid over a fixed point set, for radius queries at build time,
// in tests and in brute-force references. Not used by the step's hot path,
// which queries the sphere tree's precomputed neighbourhoods instead.
#pragma once

#include "core/types.h"

namespace gs {

class PointGrid {
 public:
  PointGrid() = default;
  /// Builds the grid over `points` (kept by pointer: they must outlive the grid).
  /// `cell` is the cell edge in metres (a query radius close to it is fastest).
  void Build(const std::vector<Vec3>& points, double cell);

  /// Appends to `out` the indices of points within `radius` of `p` (unordered).
  void Query(const Vec3& p, double radius, std::vector<int>* out) const;
  /// Index of the nearest point within `max_radius`, or -1.
  int Nearest(const Vec3& p, double max_radius) const;

  double cell() const { return cell_; }

 private:
  int64_t Key(int64_t ix, int64_t iy, int64_t iz) const;
  const std::vector<Vec3>* points_ = nullptr;
  double cell_ = 1.0;
  Vec3 origin_ = Vec3::Zero();
  int64_t nx_ = 0, ny_ = 0, nz_ = 0;
  std::vector<int> cell_start_;  // CSR over cells: size nx*ny*nz + 1
  std::vector<int> cell_items_;
};

}  // namespace gs
