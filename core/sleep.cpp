// Sleep: bodies at rest skip collision detection (SleepParams in world.h,
// docs/skip.md). A sleeping body keeps every other part of the step (free
// motion, contact space, solver, constrained motion); only the collision
// detection of its pairs against sleeping bodies or bodies that do not move is
// replaced by the last step's contacts, moved rigidly with the two poses.
//
//   UpdateSleep          end of step   rest times; bodies that have rested long
//                                      enough and that no awake moving body can
//                                      reach fall asleep, as a group
//   WakeSleepingBodies   after free    drift, drive, gravity, an awake moving
//                        motion        body's bounding sphere: wake (repeated, so
//                                      that a whole resting stack wakes together)
//   PairAsleep /         pair loop of  last contacts of the pair instead of the
//   ReuseContacts        collision_detection.cpp   broad and narrow phase
#include <algorithm>
#include <cmath>

#include "core/world.h"

namespace gs {
namespace {

bool SamePose(const Pose& a, const Pose& b) { return a.t == b.t && a.R == b.R; }

bool SameDrive(const Drive& a, const Drive& b) {
  return a.enabled == b.enabled && a.stiffness == b.stiffness && a.damping == b.damping &&
         a.angular_stiffness == b.angular_stiffness && a.angular_damping == b.angular_damping && a.force == b.force &&
         a.torque == b.torque &&
         a.max_force == b.max_force && SamePose(a.target, b.target);
}

// a body that does not move this step: fixed, or kinematic and not moved since the last step
bool Stationary(const Body& b) { return b.articulation < 0 && SamePose(b.pose, b.pose_prev); }

// a body that can carry contact to a sleeping one: awake with dofs, or a moved kinematic body
bool AwakeMover(const Body& b) { return b.articulation >= 0 ? !b.asleep : !Stationary(b); }

// farthest any point of the body moved from `from` to `to` (bounded through its root sphere)
double Drift(const Body& b, const Pose& from, const Pose& to) {
  if (b.geometry.is_plane) return (to.t - from.t).norm() + (to.R - from.R).norm() * 1e3;
  const TreeNode& root = b.geometry.tree.node(b.geometry.tree.root());
  return (to.Apply(root.center) - from.Apply(root.center)).norm() +
         (to.R - from.R).norm() * b.geometry.tree.radius(b.geometry.tree.root());
}

bool Reaches(const World& w, const Body& a, const Body& b) {
  return RootsOverlap(a.Shape(), a.pose, b.Shape(), b.pose, w.params.collision.contact_threshold);
}

void Wake(Body& b) {
  b.asleep = false;
  b.rest_time = 0.0;
}

}  // namespace

void World::WakeAll() {
  may_carry_ = false;  // a state changed by hand: its contacts are detected
  for (Body& b : bodies) {
    Wake(b);
    if (b.deform.enabled()) b.AllLive();
  }
}

void WakeSleepingBodies(World& w) {
  w.reuse_cursor = 0;
  w.carry_cursor_ = 0;
  const bool enabled = w.params.sleep.enabled;
  const bool gravity_changed = w.params.gravity != w.sleep_gravity;
  w.sleep_gravity = w.params.gravity;
  bool any = false;
  for (Body& b : w.bodies) {
    if (!b.asleep) continue;
    if (!enabled || gravity_changed || !SameDrive(b.drive, b.sleep_drive) ||
        Drift(b, b.sleep_pose, b.pose) > w.params.sleep.max_drift)
      Wake(b);
    any |= b.asleep;
  }
  if (!any) {
    // pairs that carry their contacts read them likewise
    if (w.carrying_) w.contacts_prev.assign(w.contacts.items.begin(), w.contacts.items.end());
    return;
  }
  // an awake moving body whose bounding sphere reaches a sleeping one wakes it;
  // the woken body moves from now on, so repeat until nothing more wakes
  const int n = static_cast<int>(w.bodies.size());
  for (bool woke = true; woke;) {
    woke = false;
    for (int i = 0; i < n; ++i) {
      Body& s = w.bodies[i];
      if (!s.asleep) continue;
      for (int j = 0; j < n && s.asleep; ++j) {
        const Body& m = w.bodies[j];
        if (j == i || !AwakeMover(m)) continue;
        if (Reaches(w, s, m)) {
          Wake(s);
          woke = true;
        }
      }
    }
  }
  any = false;
  for (const Body& b : w.bodies) {
    if (!b.asleep) continue;
    any = true;
    ++w.profile.work.bodies_asleep;
  }
  // the pairs kept asleep (or carried) read the last contacts (still in the buffer:
  // detection clears it next)
  if (any || w.carrying_) w.contacts_prev.assign(w.contacts.items.begin(), w.contacts.items.end());
}

bool PairAsleep(const World& w, int i, int j) {
  const Body& a = w.bodies[i];
  const Body& b = w.bodies[j];
  if (!a.asleep && !b.asleep) return false;
  return (a.asleep || Stationary(a)) && (b.asleep || Stationary(b));
}

void ReuseContacts(World& w, int i, int j, bool carried) {
  ++(carried ? w.profile.work.pairs_carried : w.profile.work.pairs_asleep);
  // the last contacts are in the pair loop's order (i, then j > i): a forward cursor finds them
  auto pair_of = [](const Contact& c) {
    return std::make_pair(std::min(c.body[0], c.body[1]), std::max(c.body[0], c.body[1]));
  };
  const std::pair<int, int> key(i, j);
  const std::vector<Contact>& prev = w.contacts_prev;
  size_t& k = w.reuse_cursor;
  while (k < prev.size() && pair_of(prev[k]) < key) ++k;
  for (; k < prev.size() && pair_of(prev[k]) == key; ++k) {
    Contact c = prev[k];
    MoveWithBodies(w, &c);
    if (w.contacts.Push(c)) ++(carried ? w.profile.work.contacts_carried : w.profile.work.contacts_reused);
  }
}

void MoveWithBodies(const World& w, Contact* c) {
  const Body& a = w.bodies[c->body[0]];
  const Body& b = w.bodies[c->body[1]];
  // rigidly moved: the surface's normal turns with body[1], the gap follows the two points
  const Vec3 old_d = a.pose_detected.Apply(c->anchor[0]) - b.pose_detected.Apply(c->anchor[1]);
  const Vec3 new_d = a.pose.Apply(c->anchor[0]) - b.pose.Apply(c->anchor[1]);
  const Vec3 n = b.pose.R * (b.pose_detected.R.transpose() * c->normal);
  c->gap += new_d.dot(n) - old_d.dot(c->normal);
  c->normal = n.normalized();
}

void UpdateSleep(World& w) {
  const SleepParams& sp = w.params.sleep;
  if (!sp.enabled) return;
  // contact counts of this step
  for (Body& b : w.bodies) {
    b.contact_count_prev = b.contact_count;
    b.contact_count = 0;
  }
  for (const Contact& c : w.contacts.items) {
    ++w.bodies[c.body[0]].contact_count;
    ++w.bodies[c.body[1]].contact_count;
  }
  const double v2 = sp.linear_velocity * sp.linear_velocity, w2 = sp.angular_velocity * sp.angular_velocity;
  bool candidates = false;
  for (Body& b : w.bodies) {
    if (b.motion != EMotion::Free || b.articulation < 0) continue;
    const bool rest = !w.profile.rejected && b.velocity.squaredNorm() < v2 && b.angular_velocity.squaredNorm() < w2 &&
                      b.contact_count == b.contact_count_prev;
    if (rest) {
      b.rest_time += w.params.dt;
    } else {
      Wake(b);
    }
    candidates |= !b.asleep && b.rest_time >= sp.time;
  }
  if (!candidates) return;
  // the candidates fall asleep together, less those an awake moving body outside them reaches
  const int n = static_cast<int>(w.bodies.size());
  std::vector<uint8_t>& in = w.sleep_set;
  for (int i = 0; i < n; ++i) {
    const Body& b = w.bodies[i];
    in[i] = b.asleep || (b.motion == EMotion::Free && b.articulation >= 0 && b.rest_time >= sp.time);
  }
  for (bool dropped = true; dropped;) {
    dropped = false;
    for (int i = 0; i < n; ++i) {
      if (!in[i] || w.bodies[i].asleep) continue;
      for (int j = 0; j < n; ++j) {
        const Body& m = w.bodies[j];
        if (j == i || in[j] || !(m.articulation >= 0 || !Stationary(m))) continue;
        if (Reaches(w, w.bodies[i], m)) {
          in[i] = 0;
          dropped = true;
          break;
        }
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    Body& b = w.bodies[i];
    if (!in[i] || b.asleep) continue;
    b.asleep = true;
    b.sleep_pose = b.pose;
    b.sleep_drive = b.drive;
  }
}

}  // namespace gs
