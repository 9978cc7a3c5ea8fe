#include "scene/scene_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

namespace gs::app {
namespace {

constexpr double kNever = std::numeric_limits<double>::infinity();
// the largest ratio of an emitting body's control spacing to a Boussinesq surface's in one-pass contact
constexpr double kOnePassSpacingRatio = 1.4;

// smallest leaf radius of a body's tree (m); 0 for a plane
double SmallestLeaf(const Body& b) {
  if (b.geometry.is_plane) return 0.0;
  const SphereTree& t = b.geometry.tree;
  double r = 1e300;
  for (int l = 0; l < t.num_leaves(); ++l) r = std::min(r, t.node(t.leaf_node(l)).rest_radius);
  return r;
}

// the initial speed of body b's fastest point (m/s): its velocity and its spin times
// how far its surface reaches from its origin (its root sphere)
double StartSpeed(const Body& b) {
  const double spin = b.angular_velocity.norm();
  if (!(spin > 0.0) || b.geometry.is_plane) return b.velocity.norm();
  const TreeNode& root = b.geometry.tree.node(b.geometry.tree.root());
  return b.velocity.norm() + spin * (root.center.norm() + root.rest_radius);
}

// how far body b moves in one step of dt from its initial velocity, falling under g:
// (M/dt^2 + B/dt) d = m g for the fall (free motion, inertial or quasi-static)
double StepTravel(const Body& b, double dt, double g) {
  const bool inertial = b.dynamics == EDynamics::Inertial;
  const double a = (inertial ? b.mass / (dt * dt) : 0.0) + b.linear_damping / dt;
  const double fall = a > 0.0 ? b.mass * g / a : 0.0;
  return fall + (inertial ? StartSpeed(b) * dt : 0.0);
}

// x rounded down to two significant digits (a suggested limit that holds as printed)
double RoundDown(double x) {
  if (!(x > 0.0) || !std::isfinite(x)) return x;
  const double unit = std::pow(10.0, std::floor(std::log10(x)) - 1.0);
  return std::floor(x / unit * (1.0 + 1e-12)) * unit;
}

bool Checked(const Body& b) { return b.motion == EMotion::Free && !b.geometry.is_plane && b.mass > 0.0; }

// the farthest a body may move in one step: half its smallest leaf, and no farther
// than the thinnest other body reaches from its centre (its core radius, the depth
// at which a pass-through is caught); `thinnest` is -1 when the leaf is the bound
struct TravelLimit {
  double travel = 0.0;
  int thinnest = -1;
};

TravelLimit AllowedTravel(const World& w, size_t i) {
  TravelLimit t{0.5 * SmallestLeaf(w.bodies[i]), -1};
  for (size_t j = 0; j < w.bodies.size(); ++j) {
    const Body& o = w.bodies[j];
    if (j == i || o.geometry.is_plane || !(o.core_radius > 0.0) || !(o.core_radius < t.travel)) continue;
    t = {o.core_radius, static_cast<int>(j)};
  }
  return t;
}

// g dt^2 + v dt = travel for an inertial body (the damping only slows the fall),
// m g dt / B = travel for a quasi-static one
double LongestStep(const Body& b, double g, double travel) {
  const double v = StartSpeed(b);
  if (b.dynamics == EDynamics::QuasiStatic)
    return b.mass * g > 0.0 && b.linear_damping > 0.0 ? travel * b.linear_damping / (b.mass * g) : kNever;
  if (g > 0.0) return (std::sqrt(v * v + 4.0 * g * travel) - v) / (2.0 * g);
  return v > 0.0 ? travel / v : kNever;
}

std::string TimeStepMessage(const World& w, int i, const TravelLimit& limit, double longest) {
  const Body& b = w.bodies[i];
  const double dt = w.params.dt, travel = StepTravel(b, dt, w.params.gravity.norm());
  char msg[700];
  if (limit.thinnest < 0)
    std::snprintf(msg, sizeof msg,
                  "time step %g s is too long: body '%s' moves %.3g mm in one step (its fastest point starting at "
                  "%.3g m/s), more than half its smallest sphere-tree leaf (radius %.3g mm); contacts would be found "
                  "too deep to resolve and it can tunnel through other bodies. Use timestep_s <= %.2g s, or fewer "
                  "control points (larger leaves)",
                  dt, b.name.c_str(), 1e3 * travel, StartSpeed(b), 2e3 * limit.travel, RoundDown(longest));
  else
    std::snprintf(msg, sizeof msg,
                  "time step %g s is too long: body '%s' moves %.3g mm in one step (its fastest point starting at "
                  "%.3g m/s), more than body '%s' reaches from its centre (%.3g mm): it can pass through it in one "
                  "step. Use timestep_s <= %.2g s",
                  dt, b.name.c_str(), 1e3 * travel, StartSpeed(b), w.bodies[limit.thinnest].name.c_str(),
                  1e3 * limit.travel, RoundDown(longest));
  return msg;
}

void TimeStep(const World& w, std::vector<IllPosed>* out) {
  const double dt = w.params.dt, g = w.params.gravity.norm();
  int worst = -1;
  double longest = kNever;
  TravelLimit worst_limit;
  for (size_t i = 0; i < w.bodies.size(); ++i) {
    const Body& b = w.bodies[i];
    if (!Checked(b)) continue;
    const TravelLimit limit = AllowedTravel(w, i);
    if (!(StepTravel(b, dt, g) > limit.travel)) continue;
    const double t = LongestStep(b, g, limit.travel);
    if (worst < 0 || t < longest) worst = static_cast<int>(i), longest = t, worst_limit = limit;
  }
  if (worst >= 0) out->push_back({IllPosed::ESite::TimeStep, worst, -1, TimeStepMessage(w, worst, worst_limit, longest)});
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

// a body of a whole tracked hand: its palm (the hand's carrier) or a phalanx
bool HandSegment(const World& w, int i) {
  if (i == w.hand.carrier) return true;
  const int f = w.bodies[i].finger;
  if (f < 0 || f >= static_cast<int>(w.hand.fingers.size())) return false;
  const auto& seg = w.hand.fingers[f].segment_body;
  return std::find(seg.begin(), seg.end(), i) != seg.end();
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
      // two fingertips of one finger, segments of one tracked finger (World::CanTouch)
      if (!w.CanTouch(i, j)) continue;
      // contacts too deep to project are not found: the core balls (Body::core_radius)
      // give a lower bound of the overlap that holds however deep it is
      const double cores = a.core_radius > 0.0 && b.core_radius > 0.0
                               ? a.core_radius + b.core_radius - (a.pose.t - b.pose.t).norm()
                               : 0.0;
      const double deepest = std::max(cores, DeepestOverlap(w, i, j, &scratch, &contacts));
      const double leaf = std::min(SmallestLeaf(a), SmallestLeaf(b));
      if (!(deepest > leaf)) continue;
      // two segments of the tracked hand are placed by its start pose, not by the scene
      const bool hand = HandSegment(w, i) && HandSegment(w, j);
      char msg[800];
      std::snprintf(msg, sizeof msg,
                    "bodies '%s' and '%s' start overlapping by %.3g mm, deeper than their smallest sphere-tree leaf "
                    "(radius %.3g mm): such contacts can be projected onto the wrong side of the surface. Move them "
                    "at least %.3g mm apart (an overlap of at most %.3g mm is resolved)%s",
                    a.name.c_str(), b.name.c_str(), 1e3 * deepest, 1e3 * leaf, 1e3 * (deepest - leaf), 1e3 * leaf,
                    hand ? ". Both are segments of the tracked hand, placed by its start pose: with self_contact "
                           "true, change that pose (hand: start_flexion_rad, position_m, rotation_deg) or the sizes "
                           "so that they clear each other, or leave self_contact false"
                         : "");
      out->push_back({IllPosed::ESite::Overlap, i, j, msg});
    }
  }
}

// Control-point spacing (m): the side of the surface patch each control point stands for.
double ControlSpacing(const Body& b) {
  const size_t n = b.geometry.tree.control_points().size();
  return n > 0 ? std::sqrt(b.geometry.area / static_cast<double>(n)) : 0.0;
}

// fn(e, s) for every pair in one-pass contact that can touch and of which one moves:
// body e emits contacts (its control points are projected) onto body s, which does not
void ForEachOnePassPair(const World& w, const std::function<void(int, int)>& fn) {
  const int n = static_cast<int>(w.bodies.size());
  for (int e = 0; e < n; ++e) {
    const Body& emitter = w.bodies[e];
    if (emitter.geometry.is_plane || !emitter.emits_contacts) continue;
    for (int s = 0; s < n; ++s) {
      const Body& surface = w.bodies[s];
      if (s == e || surface.geometry.is_plane || surface.emits_contacts) continue;
      if ((emitter.articulation < 0 && surface.articulation < 0) || !w.CanTouch(e, s)) continue;
      fn(e, s);
    }
  }
}

// In one-pass contact only the emitting body's control points touch the other body's
// surface. On a Boussinesq surface (a 1/r kernel) each contact presses a patch of the
// surface's spacing, and between the emitter's points the surface is free to bulge up
// into it: with the emitter's points farther apart than the surface's the contact is too
// soft (docs/collision.md, "One-pass contact on a Boussinesq surface": a rigid sphere
// 2 % deep at 1.2x, 8 % at 1.7x, 18 % at 2x). Gaussian kernels are smooth at their
// influence radius and do not see the sampling.
void OnePassSampling(const World& w, std::vector<IllPosed>* out) {
  ForEachOnePassPair(w, [&](int e, int s) {
    const Body &emitter = w.bodies[e], &surface = w.bodies[s];
    if (surface.deform.params().model != EDeformation::Boussinesq || !surface.deform.enabled()) return;
    const double se = ControlSpacing(emitter), ss = surface.deform.spacing();
    if (!(se > kOnePassSpacingRatio * ss)) return;
    const double needed = std::ceil(emitter.geometry.area / std::pow(kOnePassSpacingRatio * ss, 2.0));
    char msg[900];
    std::snprintf(msg, sizeof msg,
                  "body '%s' touches the Boussinesq surface of '%s' in one-pass contact (contact_points: false on "
                  "'%s'), but its control points are %.3g mm apart against that surface's %.3g mm: between them the "
                  "surface bulges into it and the contact comes out too soft (%.2gx the spacing; at most %.1fx is "
                  "resolved). Give '%s' control_points >= %.0f, or set contact_points: true on '%s'",
                  emitter.name.c_str(), surface.name.c_str(), surface.name.c_str(), 1e3 * se, 1e3 * ss, se / ss,
                  kOnePassSpacingRatio, emitter.name.c_str(), needed, surface.name.c_str());
    out->push_back({IllPosed::ESite::Sampling, e, s, msg});
  });
}

// The smallest radius of curvature of a procedural shape's smooth surface (m), where
// it sinks deepest between another body's control points or bulges most between its
// own; infinite for flat faces (a box) and for meshes, whose curvature is not known here.
double SmallestCurvatureRadius(const ShapeDesc& s) {
  switch (s.type) {
    case EShape::Sphere:
    case EShape::Capsule:
    case EShape::Cylinder:
      return s.radius;
    case EShape::Ellipsoid: {
      const double a = s.semi_axes.maxCoeff(), c = s.semi_axes.minCoeff();
      return c * c / a;
    }
    default:
      return kNever;
  }
}

// In one-pass contact a curved receiving surface rests on the emitting body's control
// points only, and sinks between them by the sagitta of the gap. A sink deeper than
// the receiver's smallest leaf is an overlap the contact does not resolve (as for
// bodies that start overlapping): the receiver goes into the emitter by that much
// wherever it lands between points, and its contact forces jump as it slides from
// point to point.
void OnePassCurvature(const World& w, std::vector<IllPosed>* out) {
  ForEachOnePassPair(w, [&](int e, int s) {
    const Body &emitter = w.bodies[e], &surface = w.bodies[s];
    // a curved emitter's own surface bulges between its points too: the two sagittas add,
    // as one of the relative radius 1 / (1/r_surface + 1/r_emitter)
    const double r = 1.0 / (1.0 / SmallestCurvatureRadius(surface.geometry.shape) +
                            1.0 / SmallestCurvatureRadius(emitter.geometry.shape));
    const double leaf = SmallestLeaf(surface);
    const double se = ControlSpacing(emitter), sink = SinkBetweenControlPoints(r, se);
    if (!(sink > leaf)) return;
    // the widest gap whose sagitta is one leaf, and the control points that give it
    const double gap = std::sqrt(leaf * (2.0 * r - leaf));
    const double needed = std::ceil(emitter.geometry.area / std::pow(gap / kGapPerSpacing, 2.0));
    const bool segment = surface.finger >= 0 && w.hand.fingers[surface.finger].body != s;
    const std::string where =
        segment ? "on the hand's phalanges (hand: phalanx: {contact_points: true})" : "on '" + surface.name + "'";
    char msg[1000];
    std::snprintf(msg, sizeof msg,
                  "body '%s' touches '%s' in one-pass contact (contact_points: false on '%s'), but its control "
                  "points are %.3g mm apart: resting on them, '%s' sinks up to %.3g mm into it between them (their "
                  "relative curvature radius %.3g mm), deeper than the %.3g mm the contact resolves (the smallest leaf "
                  "of its sphere tree). Give '%s' control_points >= %.0f, or set contact_points: true %s",
                  emitter.name.c_str(), surface.name.c_str(), surface.name.c_str(), 1e3 * se, surface.name.c_str(),
                  1e3 * sink, 1e3 * r, 1e3 * leaf, emitter.name.c_str(), needed, where.c_str());
    out->push_back({IllPosed::ESite::Sampling, e, s, msg});
  });
}

}  // namespace

double SinkBetweenControlPoints(double radius, double spacing) {
  const double gap = kGapPerSpacing * spacing;
  return gap >= radius ? radius : radius - std::sqrt(radius * radius - gap * gap);
}

double LongestTimeStep(const Body& b, double g) { return LongestStep(b, g, 0.5 * SmallestLeaf(b)); }

std::vector<IllPosed> FindIllPosed(const World& w) {
  std::vector<IllPosed> out;
  TimeStep(w, &out);
  Overlaps(w, &out);
  OnePassSampling(w, &out);
  OnePassCurvature(w, &out);
  return out;
}

std::string IllPosedReason(const World& w) {
  const std::vector<IllPosed> all = FindIllPosed(w);
  return all.empty() ? "" : all.front().message;
}

}  // namespace gs::app
