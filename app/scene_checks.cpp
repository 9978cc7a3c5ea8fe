#include "app/scene_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace gs::app {
namespace {

// smallest leaf radius of a body's tree (m); 0 for a plane
double SmallestLeaf(const Body& b) {
  if (b.geometry.is_plane) return 0.0;
  const SphereTree& t = b.geometry.tree;
  double r = 1e300;
  for (int l = 0; l < t.num_leaves(); ++l) r = std::min(r, t.node(t.leaf_node(l)).rest_radius);
  return r;
}

}  // namespace

std::string IllPosedReason(const World& w) {
  char msg[512];
  const double dt = w.params.dt, g = w.params.gravity.norm();
  // one step of fall from rest, (M/dt^2 + B/dt) d = m g (free motion, inertial or quasi-static)
  for (const Body& b : w.bodies) {
    if (b.motion != EMotion::Free || b.geometry.is_plane || b.mass <= 0.0) continue;
    const double a = (b.dynamics == EDynamics::Inertial ? b.mass / (dt * dt) : 0.0) + b.linear_damping / dt;
    if (!(a > 0.0)) continue;
    const double fall = b.mass * g / a;
    const double leaf = SmallestLeaf(b);
    if (fall > 0.5 * leaf) {
      std::snprintf(msg, sizeof msg,
                    "time step %g s is too long: body '%s' falls %.3g mm in one step from rest, more than half its "
                    "smallest sphere-tree leaf (radius %.3g mm); contacts would be found too deep to resolve and it "
                    "can tunnel through other bodies. Use timestep_s <= %.2g s, or fewer control points (larger leaves)",
                    dt, b.name.c_str(), 1e3 * fall, 1e3 * leaf,
                    b.dynamics == EDynamics::Inertial ? std::sqrt(0.5 * leaf / g) : dt * 0.5 * leaf / fall);
      return msg;
    }
  }
  // starting overlaps between point-based bodies
  const int n = static_cast<int>(w.bodies.size());
  CollisionScratch scratch;
  int max_leaves = 1;
  for (const Body& b : w.bodies) max_leaves = std::max(max_leaves, b.geometry.is_plane ? 0 : b.geometry.tree.num_leaves());
  scratch.Reserve(max_leaves, 65536);
  ContactBuffer contacts;
  contacts.Reserve(65536);
  for (int i = 0; i < n; ++i) {
    const Body& a = w.bodies[i];
    if (a.geometry.is_plane) continue;
    for (int j = i + 1; j < n; ++j) {
      const Body& b = w.bodies[j];
      if (b.geometry.is_plane || (a.articulation < 0 && b.articulation < 0)) continue;
      if (a.finger >= 0 && a.finger == b.finger) continue;
      const CollisionShape sa = a.Shape(), sb = b.Shape();
      if (!RootsOverlap(sa, a.pose, sb, b.pose, w.params.collision.contact_threshold)) continue;
      contacts.Clear();
      CollisionStats stats;
      CollidePair(i, sa, a.pose, j, sb, b.pose, w.params.collision, &scratch, &contacts, &stats);
      double deepest = 0.0;
      for (const Contact& c : contacts.items) deepest = std::max(deepest, -c.gap);
      const double leaf = std::min(SmallestLeaf(a), SmallestLeaf(b));
      if (deepest > leaf) {
        std::snprintf(msg, sizeof msg,
                      "bodies '%s' and '%s' start overlapping by %.3g mm, deeper than their smallest sphere-tree "
                      "leaf (radius %.3g mm): such contacts can be projected onto the wrong side of the surface. "
                      "Separate them (or overlap by less than a leaf)",
                      a.name.c_str(), b.name.c_str(), 1e3 * deepest, 1e3 * leaf);
        return msg;
      }
    }
  }
  return "";
}

}  // namespace gs::app
