#include "core/sym_eigen3.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

namespace gs {
namespace {

void CheckDecomposition(const Mat3& A) {
  Vec3 values;
  Mat3 V;
  SymmetricEigen3(A, &values, &V);
  const double scale = std::max(A.cwiseAbs().maxCoeff(), 1e-300);
  EXPECT_LE(values[0], values[1] + 1e-12 * scale);
  EXPECT_LE(values[1], values[2] + 1e-12 * scale);
  EXPECT_LT((V.transpose() * V - Mat3::Identity()).norm(), 1e-10);
  for (int i = 0; i < 3; ++i) EXPECT_LT((A * V.col(i) - values[i] * V.col(i)).norm(), 1e-9 * scale) << A;
  // the same eigenvalues as Eigen's iterative solver
  Eigen::SelfAdjointEigenSolver<Mat3> ref(A);
  EXPECT_LT((ref.eigenvalues() - values).norm(), 1e-9 * scale);
  const Vec3 n = SmallestEigenvector(A);
  EXPECT_NEAR(n.norm(), 1.0, 1e-12);
  EXPECT_LT((A * n - values[0] * n).norm(), 1e-9 * scale);
}

TEST(SymEigen3, RandomSymmetricMatricesAtManyScales) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nd;
  for (int t = 0; t < 2000; ++t) {
    Mat3 M;
    for (int i = 0; i < 9; ++i) M(i / 3, i % 3) = nd(rng);
    const Mat3 A = (M + M.transpose()) * std::pow(10.0, (t % 13) - 6);
    CheckDecomposition(A);
  }
}

TEST(SymEigen3, RepeatedAndDegenerateEigenvalues) {
  CheckDecomposition(Mat3::Identity());
  CheckDecomposition(Vec3(1, 1, 2).asDiagonal());
  CheckDecomposition(Vec3(2, 1, 1).asDiagonal());
  CheckDecomposition(Vec3(0, 0, 1).asDiagonal());
  const Vec3 a = Vec3(1, 2, 3).normalized();
  CheckDecomposition(a * a.transpose());                        // rank 1
  CheckDecomposition(Mat3::Identity() - a * a.transpose());     // a plane: smallest along a
  EXPECT_NEAR(std::abs(SmallestEigenvector(Mat3::Identity() - a * a.transpose()).dot(a)), 1.0, 1e-12);
  Vec3 v;
  Mat3 V;
  SymmetricEigen3(Mat3::Zero(), &v, &V);
  EXPECT_EQ(v, Vec3::Zero());
  EXPECT_NEAR(SmallestEigenvector(Mat3::Zero()).norm(), 1.0, 1e-12);
}

}  // namespace
}  // namespace gs
