// Camera matrices, projection and the default framing.
#include "render/camera.h"

#include <algorithm>
#include <cmath>

namespace gs::render {

Mat4 Camera::View() const {
  const Vec3 f = (target - position).normalized();
  const Vec3 s = f.cross(up).normalized();
  const Vec3 u = s.cross(f);
  Mat4 m = Mat4::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(position);
  m(1, 3) = -u.dot(position);
  m(2, 3) = f.dot(position);
  return m;
}

Mat4 Camera::Projection(double aspect) const {
  const double dist = (target - position).norm();
  const double n = std::max(1e-4, 0.02 * dist), f = 50.0 * dist + 1.0;
  const double t = 1.0 / std::tan(0.5 * fov_deg * M_PI / 180.0);
  Mat4 m = Mat4::Zero();
  m(0, 0) = t / aspect;
  m(1, 1) = t;
  m(2, 2) = -(f + n) / (f - n);
  m(2, 3) = -2.0 * f * n / (f - n);
  m(3, 2) = -1.0;
  return m;
}

bool Camera::Project(const Vec3& p, int width, int height, double* x, double* y) const {
  const Eigen::Vector4d clip = Projection(double(width) / height) * View() * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
  if (!(clip.w() > 0)) return false;
  const double nx = clip.x() / clip.w(), ny = clip.y() / clip.w();
  *x = 0.5 * (nx + 1.0) * width;
  *y = 0.5 * (1.0 - ny) * height;
  return true;
}

double Camera::PixelsPerMetre(double depth, int height) const {
  return 0.5 * height / (std::tan(0.5 * fov_deg * M_PI / 180.0) * depth);
}

bool Camera::Valid() const {
  const Vec3 d = target - position;
  if (!position.allFinite() || !target.allFinite() || !up.allFinite()) return false;
  if (!(d.norm() > 1e-9) || !(fov_deg > 0 && fov_deg < 180)) return false;
  return d.normalized().cross(up).norm() > 1e-6 * up.norm() && up.norm() > 0;
}

Camera DefaultCamera(const SnapshotRig& rig, const WorldSnapshot& s, double fov_deg, double margin,
                     const std::vector<Vec3>& sweep) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  bool any = false;
  auto add = [&](const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    any = true;
  };
  for (size_t b = 0; b < rig.bodies.size() && b < s.bodies.size(); ++b) {
    const SurfaceRig& r = rig.bodies[b];
    if (r.is_plane) continue;
    // a body's bounding box corners in the world
    Vec3 blo = Vec3::Constant(1e300), bhi = Vec3::Constant(-1e300);
    for (const Vec3& p : r.rest_p) {
      blo = blo.cwiseMin(p);
      bhi = bhi.cwiseMax(p);
    }
    if (r.rest_p.empty()) continue;
    for (int c = 0; c < 8; ++c)
      add(s.bodies[b].pose.Apply(Vec3(c & 1 ? bhi.x() : blo.x(), c & 2 ? bhi.y() : blo.y(), c & 4 ? bhi.z() : blo.z())));
  }
  for (const FingerState& f : s.fingers)
    for (const Vec3& p : f.points) add(p);
  Camera cam;
  cam.fov_deg = fov_deg;
  if (!any) return cam;
  const Vec3 lo0 = lo, hi0 = hi;
  for (const Vec3& d : sweep)
    if (d.allFinite()) {
      lo = lo.cwiseMin(lo0 + d);
      hi = hi.cwiseMax(hi0 + d);
    }
  const Vec3 centre = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 1e-3);
  const double dist = margin * radius / std::sin(0.5 * fov_deg * M_PI / 180.0);
  // from the front (-y), a little to the right and above: in the paper's grasp the
  // thumb (-x) and the two fingers (+x) press on the faces seen edge-on left and right
  const Vec3 dir = Vec3(0.12, -1.0, 0.4).normalized();
  cam.target = centre;
  cam.position = centre + dist * dir;
  return cam;
}

}  // namespace gs::render
