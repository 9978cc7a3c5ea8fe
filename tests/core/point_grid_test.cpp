#include "core/point_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace gs {
namespace {

TEST(PointGrid, QueryMatchesBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> pts(2000);
  for (Vec3& p : pts) p = Vec3(u(rng), u(rng), 0.1 * u(rng));
  PointGrid grid;
  grid.Build(pts, 0.1);
  for (int q = 0; q < 200; ++q) {
    const Vec3 c(u(rng) * 1.2, u(rng) * 1.2, u(rng) * 0.2);
    const double r = 0.02 + 0.2 * std::abs(u(rng));
    std::vector<int> got;
    grid.Query(c, r, &got);
    std::sort(got.begin(), got.end());
    std::vector<int> want;
    for (int i = 0; i < static_cast<int>(pts.size()); ++i)
      if ((pts[i] - c).norm() <= r) want.push_back(i);
    ASSERT_EQ(got, want) << "query " << q;
    const int nearest = grid.Nearest(c, 10.0);
    int best = 0;
    for (int i = 1; i < static_cast<int>(pts.size()); ++i)
      if ((pts[i] - c).squaredNorm() < (pts[best] - c).squaredNorm()) best = i;
    EXPECT_EQ(nearest, best);
  }
}

TEST(PointGrid, DegenerateInputsStayBounded) {
  // all points identical, and a huge outlier: the grid must not explode in size
  std::vector<Vec3> pts(100, Vec3(0.5, 0.5, 0.5));
  pts.push_back(Vec3(1e6, 0, 0));
  PointGrid grid;
  grid.Build(pts, 1e-6);
  std::vector<int> got;
  grid.Query(Vec3(0.5, 0.5, 0.5), 1e-3, &got);
  EXPECT_EQ(got.size(), 100u);
  PointGrid empty;
  std::vector<Vec3> none;
  empty.Build(none, 0.1);
  got.clear();
  empty.Query(Vec3::Zero(), 1.0, &got);
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(empty.Nearest(Vec3::Zero(), 1.0), -1);
}

}  // namespace
}  // namespace gs
