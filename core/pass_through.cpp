// Pass-through check (World::Step, constrained motion): a body whose centre came
// inside another body during a step has passed through its surface, and the
// contacts of the next steps would push it out on the wrong side. Such a step is
// rejected like a non-finite one, so that a run reports it instead of going on.
// Only bodies with a core (Body::core_radius > 0: their centre lies inside their
// surface) are checked; a flat sheet of points may rest with its centre on a plane.
#include <algorithm>
#include <cmath>

#include "core/world.h"

namespace gs {

const char* const kPassThroughReason =
    "pass-through: a body's centre entered another body during the step (World::last_pass_through names them)";

namespace {

// closest distance to the origin of the segment d0 -> d1
double ClosestApproach(const Vec3& d0, const Vec3& d1) {
  const Vec3 e = d1 - d0;
  const double ee = e.squaredNorm();
  const double s = ee > 0.0 ? std::clamp(-d0.dot(e) / ee, 0.0, 1.0) : 0.0;
  return (d0 + s * e).norm();
}

bool Moves(const Body& b) { return b.motion == EMotion::Free || b.motion == EMotion::Fingertip; }

void Record(World& w, int body, int other, double distance, double core) {
  PassThrough& p = w.last_pass_through;
  p.body = body;
  p.other = other;
  p.step = w.step_count + 1;
  p.time = w.time + w.params.dt;
  p.distance = distance;
  p.core = core;
}

// the centre of a moving body crossing a plane from above
bool ThroughPlane(World& w, int plane, int i) {
  const Body& p = w.bodies[plane];
  const Body& b = w.bodies[i];
  const double h0 = p.pose.ApplyInverse(b.pose_prev.t).z(), h1 = p.pose.ApplyInverse(b.pose.t).z();
  if (!(h0 >= 0.0 && h1 < 0.0)) return false;
  Record(w, i, plane, h1, 0.0);
  return true;
}

// the centres of two bodies closer than the larger core radius at some point of the step
bool ThroughBody(World& w, int i, int j) {
  const Body& a = w.bodies[i];
  const Body& b = w.bodies[j];
  const double core = std::max(a.core_radius, b.core_radius);
  const Vec3 d0 = a.pose_prev.t - b.pose_prev.t, d1 = a.pose.t - b.pose.t;
  if (d0.squaredNorm() < core * core) return false;  // already that close: counted when it happened
  const double closest = ClosestApproach(d0, d1);
  if (!(closest < core)) return false;
  // the one that moved more went through the other
  const bool a_moved = (a.pose.t - a.pose_prev.t).squaredNorm() >= (b.pose.t - b.pose_prev.t).squaredNorm();
  Record(w, a_moved ? i : j, a_moved ? j : i, closest, core);
  return true;
}

}  // namespace

double CoreRadius(const BodyGeometry& g) {
  const PointCloud& c = g.cloud;
  if (c.size() == 0) return 0.0;
  size_t nearest = 0;
  double best = c.positions[0].squaredNorm();
  for (size_t k = 1; k < c.size(); ++k) {
    const double d = c.positions[k].squaredNorm();
    if (d < best) best = d, nearest = k;
  }
  const bool inside = c.normals.size() == c.size() && c.positions[nearest].dot(c.normals[nearest]) > 0.0;
  return inside ? std::sqrt(best) : 0.0;
}

bool FindPassThrough(World& w) {
  const int n = static_cast<int>(w.bodies.size());
  for (int i = 0; i < n; ++i) {
    const Body& a = w.bodies[i];
    for (int j = i + 1; j < n; ++j) {
      const Body& b = w.bodies[j];
      if (!Moves(a) && !Moves(b)) continue;
      // two fingertips of one finger, segments of one tracked finger (World::CanTouch)
      if (!w.CanTouch(i, j)) continue;
      if (a.geometry.is_plane || b.geometry.is_plane) {
        const int plane = a.geometry.is_plane ? i : j, other = a.geometry.is_plane ? j : i;
        const Body& o = w.bodies[other];
        // a body without a core (a sheet, a ring) may rest with its centre on the plane
        if (!o.geometry.is_plane && Moves(o) && o.core_radius > 0.0 && ThroughPlane(w, plane, other)) return true;
        continue;
      }
      if (a.core_radius > 0.0 && b.core_radius > 0.0 && ThroughBody(w, i, j)) return true;
    }
  }
  return false;
}

}  // namespace gs
