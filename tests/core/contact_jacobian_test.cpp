#include "core/contact_jacobian.h"

#include <gtest/gtest.h>

#include <random>

namespace gs {
namespace {

TEST(ContactJacobian, FreeSideBlockIsTheDelassusBlockOfTheLeverArm) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int compared = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    // a free body's mobility: symmetric positive linear and angular blocks of very
    // different scales (a 0.15 kg box: ~7 m/(N s^2); its rotation: ~1e4)
    Articulation a;
    Eigen::Matrix3d ml, ma;
    for (int i = 0; i < 9; ++i) {
      ml.data()[i] = u(rng);
      ma.data()[i] = u(rng);
    }
    a.a_inv.setZero();
    a.a_inv.topLeftCorner<3, 3>() = 7.0 * (ml * ml.transpose() + Mat3::Identity());
    a.a_inv.bottomRightCorner<3, 3>() = 1e4 * (ma * ma.transpose() + 0.1 * Mat3::Identity());
    const Vec3 lever = 0.03 * Vec3(u(rng), u(rng), u(rng));
    const Vec3 n = Vec3(u(rng), u(rng), u(rng)).normalized();
    const Vec3 t1 = AnyPerpendicular(n);
    const Vec3 t2 = n.cross(t1);
    // every other trial, a touch offset: the normal row's arm ends at lever + arm
    const Vec3 arm = trial % 2 ? Vec3(0.002 * Vec3(u(rng), u(rng), u(rng))) : Vec3::Zero();
    Mat3 w = Mat3::Zero();
    AddFreeSideBlock(a, lever, arm.cross(n), n, t1, t2, &w);
    // the Delassus block formed whole: H A^-1 H^T with H = frame [I, -[l]x], its
    // normal row n^T [I, -[l + arm]x]
    const auto skew = [](const Vec3& l) {
      Mat3 m;
      m << 0, -l.z(), l.y(), l.z(), 0, -l.x(), -l.y(), l.x(), 0;
      return m;
    };
    Mat3 frame;
    frame.row(0) = n;
    frame.row(1) = t1;
    frame.row(2) = t2;
    Eigen::Matrix<double, 3, 6> h;
    h.leftCols<3>() = frame;
    h.rightCols<3>() = -frame * skew(lever);
    h.row(0).tail<3>() = -n.transpose() * skew(lever + arm);
    const Mat3 direct = h * a.a_inv * h.transpose();
    ASSERT_LT((w - direct).norm(), 1e-10 * direct.norm()) << "trial " << trial;
    ASSERT_EQ(w, w.transpose()) << "trial " << trial;  // symmetric by construction
    ++compared;
  }
  EXPECT_EQ(compared, 2000);
}

}  // namespace
}  // namespace gs
