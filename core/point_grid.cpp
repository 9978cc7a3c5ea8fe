#include "core/point_grid.h"

#include <algorithm>
#include <limits>

namespace gs {

void PointGrid::Build(const std::vector<Vec3>& points, double cell) {
  points_ = &points;
  cell_ = cell > 0 ? cell : 1.0;
  cell_start_.clear();
  cell_items_.clear();
  if (points.empty()) {
    nx_ = ny_ = nz_ = 0;
    return;
  }
  Vec3 lo = points[0], hi = points[0];
  for (const Vec3& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // keep the cell count bounded (at most ~4 cells per point) for degenerate inputs
  const double max_cells = 4.0 * static_cast<double>(points.size()) + 64.0;
  for (;;) {
    const Vec3 extent = (hi - lo) / cell_;
    const double cells = (std::floor(extent.x()) + 1) * (std::floor(extent.y()) + 1) * (std::floor(extent.z()) + 1);
    if (cells <= max_cells) break;
    cell_ *= 1.5;
  }
  origin_ = lo;
  nx_ = static_cast<int64_t>((hi.x() - lo.x()) / cell_) + 1;
  ny_ = static_cast<int64_t>((hi.y() - lo.y()) / cell_) + 1;
  nz_ = static_cast<int64_t>((hi.z() - lo.z()) / cell_) + 1;
  const int64_t n_cells = nx_ * ny_ * nz_;
  std::vector<int> key_of(points.size());
  cell_start_.assign(static_cast<size_t>(n_cells) + 1, 0);
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3 q = (points[i] - origin_) / cell_;
    const int64_t k = Key(static_cast<int64_t>(q.x()), static_cast<int64_t>(q.y()), static_cast<int64_t>(q.z()));
    key_of[i] = static_cast<int>(k);
    ++cell_start_[static_cast<size_t>(k) + 1];
  }
  for (int64_t c = 0; c < n_cells; ++c) cell_start_[c + 1] += cell_start_[c];
  cell_items_.resize(points.size());
  std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (size_t i = 0; i < points.size(); ++i) cell_items_[fill[key_of[i]]++] = static_cast<int>(i);
}

int64_t PointGrid::Key(int64_t ix, int64_t iy, int64_t iz) const {
  ix = std::clamp<int64_t>(ix, 0, nx_ - 1);
  iy = std::clamp<int64_t>(iy, 0, ny_ - 1);
  iz = std::clamp<int64_t>(iz, 0, nz_ - 1);
  return (iz * ny_ + iy) * nx_ + ix;
}

void PointGrid::Query(const Vec3& p, double radius, std::vector<int>* out) const {
  if (!points_ || nx_ == 0 || !(radius >= 0)) return;
  const Vec3 lo = (p - origin_ - Vec3::Constant(radius)) / cell_;
  const Vec3 hi = (p - origin_ + Vec3::Constant(radius)) / cell_;
  if (hi.x() < 0 || hi.y() < 0 || hi.z() < 0) return;
  if (lo.x() >= nx_ || lo.y() >= ny_ || lo.z() >= nz_) return;
  const int64_t x0 = std::max<int64_t>(0, static_cast<int64_t>(std::floor(lo.x())));
  const int64_t y0 = std::max<int64_t>(0, static_cast<int64_t>(std::floor(lo.y())));
  const int64_t z0 = std::max<int64_t>(0, static_cast<int64_t>(std::floor(lo.z())));
  const int64_t x1 = std::min<int64_t>(nx_ - 1, static_cast<int64_t>(std::floor(hi.x())));
  const int64_t y1 = std::min<int64_t>(ny_ - 1, static_cast<int64_t>(std::floor(hi.y())));
  const int64_t z1 = std::min<int64_t>(nz_ - 1, static_cast<int64_t>(std::floor(hi.z())));
  const double r2 = radius * radius;
  const std::vector<Vec3>& pts = *points_;
  for (int64_t z = z0; z <= z1; ++z)
    for (int64_t y = y0; y <= y1; ++y)
      for (int64_t x = x0; x <= x1; ++x) {
        const int64_t k = (z * ny_ + y) * nx_ + x;
        for (int j = cell_start_[k]; j < cell_start_[k + 1]; ++j) {
          const int i = cell_items_[j];
          if ((pts[i] - p).squaredNorm() <= r2) out->push_back(i);
        }
      }
}

int PointGrid::Nearest(const Vec3& p, double max_radius) const {
  thread_local std::vector<int> buf;
  buf.clear();
  Query(p, max_radius, &buf);
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (int i : buf) {
    const double d2 = ((*points_)[i] - p).squaredNorm();
    if (d2 < best_d2 || (d2 == best_d2 && i < best)) {
      best_d2 = d2;
      best = i;
    }
  }
  return best;
}

}  // namespace gs
