// Carried contacts (WorldParams::carry_contacts_after_s): in a step short of time, a
// body pair whose bodies have hardly moved against each other since the last step
// keeps that step's contacts, moved with the bodies (MoveWithBodies), instead of
// being detected. Two bounds make it so:
//   - no point of either body moved against the other by the contact threshold: a
//     surface that was farther than the threshold from the other cannot have reached
//     it, so no contact is missed;
//   - no contact's two points slid against the other body (across the contact's
//     normal) by more than carry_max_slide_m: where each force acts (its anchors,
//     the touching point) stays where detection would put it; along the normal the
//     moved gap follows the motion. (A rolling ball's touching point leaves
//     the material point it was found at; carried, its normal force would act ahead
//     of the ball's centre and speed the rolling up.)
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/world.h"

namespace gs {
namespace {

// the pose of a seen from b
Pose Relative(const Pose& a, const Pose& b) { return b.Inverse() * a; }

// rotation angle of R (rad)
double Angle(const Mat3& R) { return std::acos(std::clamp(0.5 * (R.trace() - 1.0), -1.0, 1.0)); }

// How far any point of body a has moved against body b since the last detection:
// a's root sphere seen from b (its centre's displacement plus its radius times the
// turn). A plane has no sphere: infinite.
double MotionAgainst(const Body& a, const Body& b) {
  if (a.geometry.is_plane) return std::numeric_limits<double>::infinity();
  const TreeNode& root = a.geometry.tree.node(a.geometry.tree.root());
  const Pose before = Relative(a.pose_detected, b.pose_detected);
  const Pose now = Relative(a.pose, b.pose);
  const double turn = Angle(now.R * before.R.transpose());
  const double radius = a.geometry.tree.radius(a.geometry.tree.root());
  return (now.Apply(root.center) - before.Apply(root.center)).norm() + turn * radius;
}

// How far a contact's point on body s has slid against the other body since the
// last detection: its anchor moved to the touching point, seen from the other body,
// across the contact's normal. (Along the normal the moved gap is exact to first
// order; across it the point where the force acts is off by the slide.)
double PointSlide(const World& w, const Contact& c, int s) {
  const Body& a = w.bodies[c.body[s]];
  const Body& b = w.bodies[c.body[1 - s]];
  const Vec3 p = c.anchor[s] + c.touch[s];
  const Vec3 d = Relative(a.pose, b.pose).Apply(p) - Relative(a.pose_detected, b.pose_detected).Apply(p);
  const Vec3 n = b.pose_detected.RotateInverse(c.normal);  // in b's frame at the detection
  return (d - d.dot(n) * n).norm();
}

std::pair<int, int> PairOf(const Contact& c) {
  return {std::min(c.body[0], c.body[1]), std::max(c.body[0], c.body[1])};
}

}  // namespace

bool PairCarried(World& w, int i, int j) {
  const Body& a = w.bodies[i];
  const Body& b = w.bodies[j];
  // a body whose contacts are not its own tree's (a rebuilt scene) is detected
  if (!(std::min(MotionAgainst(a, b), MotionAgainst(b, a)) < w.params.collision.contact_threshold)) return false;
  // the pair's last contacts (in the pair loop's order: a forward cursor finds them)
  const std::vector<Contact>& prev = w.contacts_prev;
  size_t& k = w.carry_cursor_;
  const std::pair<int, int> key(i, j);
  while (k < prev.size() && PairOf(prev[k]) < key) ++k;
  for (size_t m = k; m < prev.size() && PairOf(prev[m]) == key; ++m)
    for (int s = 0; s < 2; ++s)
      if (!(PointSlide(w, prev[m], s) <= w.params.carry_max_slide_m)) return false;
  return true;
}

}  // namespace gs
