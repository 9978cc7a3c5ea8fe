#include "app/scene_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace gs::app {
namespace {

constexpr double kNever = std::numeric_limits<double>::infinity();

// smallest leaf radius of a body's tree (m); 0 for a plane
double SmallestLeaf(const Body& b) {
  if (b.geometry.is_plane) return 0.0;
  const SphereTree& t = b.geometry.tree;
  double r = 1e300;
  for (int l = 0; l < t.num_leaves(); ++l) r = std::min(r, t.node(t.leaf_node(l)).rest_radius);
  return r;
}

// how far body b moves in one step of dt from its initial velocity, falling under g:
// (M/dt^2 + B/dt) d = m g for the fall (free motion, inertial or quasi-static)
double StepTravel(const Body& b, double dt, double g) {
  const bool inertial = b.dynamics == EDynamics::Inertial;
  const double a = (inertial ? b.mass / (dt * dt) : 0.0) + b.linear_damping / dt;
  const double fall = a > 0.0 ? b.mass * g / a : 0.0;
  return fall + (inertial ? b.velocity.norm() * dt : 0.0);
}

// x rounded down to two significant digits (a suggested limit that holds as printed)
double RoundDown(double x) {
  if (!(x > 0.0) || !std::isfinite(x)) return x;
  const double unit = std::pow(10.0, std::floor(std::log10(x)) - 1.0);
  return std::floor(x / unit * (1.0 + 1e-12)) * unit;
}

bool Checked(const Body& b) { return b.motion == EMotion::Free && !b.geometry.is_plane && b.mass > 0.0; }

void TimeStep(const World& w, std::vector<IllPosed>* out) {
  const double dt = w.params.dt, g = w.params.gravity.norm();
  int worst = -1;
  double longest = kNever;
  for (size_t i = 0; i < w.bodies.size(); ++i) {
    const Body& b = w.bodies[i];
    if (!Checked(b) || !(StepTravel(b, dt, g) > 0.5 * SmallestLeaf(b))) continue;
    const double t = LongestTimeStep(b, g);
    if (worst < 0 || t < longest) worst = static_cast<int>(i), longest = t;
  }
  if (worst < 0) return;
  const Body& b = w.bodies[worst];
  char msg[640];
  std::snprintf(msg, sizeof msg,
                "time step %g s is too long: body '%s' moves %.3g mm in one step (falling from %.3g m/s), more than "
                "half its smallest sphere-tree leaf (radius %.3g mm); contacts would be found too deep to resolve and "
                "it can tunnel through other bodies. Use timestep_s <= %.2g s, or fewer control points (larger leaves)",
                dt, b.name.c_str(), 1e3 * StepTravel(b, dt, g), b.velocity.norm(), 1e3 * SmallestLeaf(b), RoundDown(longest));
  out->push_back({IllPosed::ESite::TimeStep, worst, -1, msg});
}

// the deepest starting overlap of two point-based bodies (m)
double DeepestOverlap(const World& w, int i, int j, CollisionScratch* scratch, ContactBuffer* contacts) {
  const Body& a = w.bodies[i];
  const Body& b = w.bodies[j];
  const CollisionShape sa = a.Shape(), sb = b.Shape();
  if (!RootsOverlap(sa, a.pose, sb, b.pose, w.params.collision.contact_threshold)) return 0.0;
  contacts->Clear();
  CollisionStats stats;
  CollidePair(i, sa, a.pose, j, sb, b.pose, w.params.collision, scratch, contacts, &stats);
  double deepest = 0.0;
  for (const Contact& c : contacts->items) deepest = std::max(deepest, -c.gap);
  return deepest;
}

void Overlaps(const World& w, std::vector<IllPosed>* out) {
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
      // contacts too deep to project are not found: the core balls (Body::core_radius)
      // give a lower bound of the overlap that holds however deep it is
      const double cores = a.core_radius > 0.0 && b.core_radius > 0.0
                               ? a.core_radius + b.core_radius - (a.pose.t - b.pose.t).norm()
                               : 0.0;
      const double deepest = std::max(cores, DeepestOverlap(w, i, j, &scratch, &contacts));
      const double leaf = std::min(SmallestLeaf(a), SmallestLeaf(b));
      if (!(deepest > leaf)) continue;
      char msg[640];
      std::snprintf(msg, sizeof msg,
                    "bodies '%s' and '%s' start overlapping by %.3g mm, deeper than their smallest sphere-tree leaf "
                    "(radius %.3g mm): such contacts can be projected onto the wrong side of the surface. Move them "
                    "at least %.3g mm apart (an overlap of at most %.3g mm is resolved)",
                    a.name.c_str(), b.name.c_str(), 1e3 * deepest, 1e3 * leaf, 1e3 * (deepest - leaf), 1e3 * leaf);
      out->push_back({IllPosed::ESite::Overlap, i, j, msg});
    }
  }
}

}  // namespace

double LongestTimeStep(const Body& b, double g) {
  const double half_leaf = 0.5 * SmallestLeaf(b), v = b.velocity.norm();
  if (b.dynamics == EDynamics::QuasiStatic) {
    // fall = m g dt / B
    return b.mass * g > 0.0 && b.linear_damping > 0.0 ? half_leaf * b.linear_damping / (b.mass * g) : kNever;
  }
  // g dt^2 + v dt = half_leaf (the damping only slows the fall)
  if (g > 0.0) return (std::sqrt(v * v + 4.0 * g * half_leaf) - v) / (2.0 * g);
  return v > 0.0 ? half_leaf / v : kNever;
}

std::vector<IllPosed> FindIllPosed(const World& w) {
  std::vector<IllPosed> out;
  TimeStep(w, &out);
  Overlaps(w, &out);
  return out;
}

std::string IllPosedReason(const World& w) {
  const std::vector<IllPosed> all = FindIllPosed(w);
  return all.empty() ? "" : all.front().message;
}

}  // namespace gs::app
