// Basic math types shared by every stage. SI units throughout (m, kg, s, N).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <vector>

namespace gs {

using Vec3 = Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Quat = Eigen::Quaterniond;

/// A rigid transform x_world = R x_body + t.
struct Pose {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();

  Vec3 Apply(const Vec3& p) const { return R * p + t; }
  Vec3 ApplyInverse(const Vec3& p) const { return R.transpose() * (p - t); }
  Vec3 Rotate(const Vec3& v) const { return R * v; }
  Vec3 RotateInverse(const Vec3& v) const { return R.transpose() * v; }
  Pose Inverse() const { return Pose{R.transpose(), -(R.transpose() * t)}; }
  /// this * other: first other, then this.
  Pose operator*(const Pose& o) const { return Pose{R * o.R, R * o.t + t}; }

  static Pose Translation(const Vec3& t) { return Pose{Mat3::Identity(), t}; }
  static Pose FromAxisAngle(const Vec3& axis, double angle, const Vec3& t = Vec3::Zero()) {
    return Pose{Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix(), t};
  }
};

inline bool IsFinite(double x) { return std::isfinite(x); }
inline bool IsFinite(const Vec3& v) { return v.allFinite(); }

/// Any unit vector perpendicular to n (n must be unit length).
inline Vec3 AnyPerpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x()) < 0.57 ? Vec3::UnitX() : (std::abs(n.y()) < 0.57 ? Vec3::UnitY() : Vec3::UnitZ());
  return n.cross(a).normalized();
}

/// The cross-product matrix: Skew(a) * b == a.cross(b).
inline Mat3 Skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// A surface sampled as points with outward unit normals, in a body's rest frame.
struct PointCloud {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;
  size_t size() const { return positions.size(); }
};

}  // namespace gs
