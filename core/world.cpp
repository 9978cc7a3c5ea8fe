#include "core/world.h"

#include <algorithm>
#include <chrono>

#include "core/float_mode.h"

namespace gs {

// memory the pair caches' first capacity may take at Finalize (bytes); past it, pairs
// reserve at their first traversal
constexpr size_t kPairCacheBudget = size_t{64} << 20;

CollisionShape Body::Shape() const {
  CollisionShape s;
  s.is_plane = geometry.is_plane;
  if (!s.is_plane) {
    s.cloud = &geometry.cloud;
    s.tree = &geometry.tree;
  }
  s.mls = geometry.mls;
  s.emits_contacts = emits_contacts;
  s.deforms = deform.enabled();
  return s;
}

Mat3 SolidInertia(const ShapeDesc& shape, double mass) {
  Mat3 I = Mat3::Zero();
  switch (shape.type) {
    case EShape::Box: {
      const Vec3 e = 2.0 * shape.half_extents;
      I.diagonal() << e.y() * e.y() + e.z() * e.z(), e.x() * e.x() + e.z() * e.z(), e.x() * e.x() + e.y() * e.y();
      I *= mass / 12.0;
      break;
    }
    case EShape::Sphere:
      I.diagonal().setConstant(0.4 * mass * shape.radius * shape.radius);
      break;
    case EShape::Ellipsoid: {
      const Vec3 a = shape.semi_axes;
      I.diagonal() << a.y() * a.y() + a.z() * a.z(), a.x() * a.x() + a.z() * a.z(), a.x() * a.x() + a.y() * a.y();
      I *= mass / 5.0;
      break;
    }
    case EShape::Cylinder:
    case EShape::Capsule:
    case EShape::Mesh: {
      // a solid cylinder of the same radius and length (capsule caps included in the length)
      const double r = shape.radius;
      const double len = 2.0 * shape.half_length + (shape.type == EShape::Capsule ? 2.0 * r : 0.0);
      const double ixx = mass * (3.0 * r * r + len * len) / 12.0;
      I.diagonal() << ixx, ixx, 0.5 * mass * r * r;
      break;
    }
  }
  return I;
}

int AddBody(World& w, const BodySpec& spec, EGeometryError* error) {
  Body b;
  b.name = spec.name;
  EGeometryError e = EGeometryError::None;
  if (spec.is_plane) {
    BuildPlaneGeometry(&b.geometry);
  } else if (spec.mesh) {
    e = BuildMeshGeometry(*spec.mesh, spec.geometry, &b.geometry);
  } else {
    e = BuildShapeGeometry(spec.shape, spec.geometry, &b.geometry);
  }
  if (error) *error = e;
  if (e != EGeometryError::None) return -1;
  b.motion = spec.is_plane ? EMotion::Fixed : spec.motion;
  b.dynamics = spec.dynamics;
  b.mass = spec.mass;
  b.inertia = spec.is_plane ? Mat3::Zero()
                            : (spec.inertia.isZero(0.0) ? SolidInertia(b.geometry.shape, spec.mass) : spec.inertia);
  b.linear_damping = spec.linear_damping;
  b.angular_damping = spec.angular_damping;
  b.pose = b.pose_prev = spec.pose;
  b.velocity = spec.velocity;
  b.angular_velocity = spec.angular_velocity;
  b.drive = spec.drive;
  b.emits_contacts = spec.emits_contacts;
  if (!spec.is_plane && spec.deformation.model != EDeformation::Rigid) {
    const int cps = b.geometry.tree.num_leaves();
    b.deform.Build(b.geometry.tree.control_points(), b.geometry.area / cps, spec.deformation, w.params.dt);
  }
  w.bodies.push_back(std::move(b));
  return static_cast<int>(w.bodies.size()) - 1;
}

double World::Friction(int a, int b) const {
  const int n = static_cast<int>(bodies.size());
  if (a < 0 || b < 0 || a >= n || b >= n || friction_.empty()) return params.default_friction;
  return friction_[static_cast<size_t>(a) * n + b];
}

void World::SetFriction(int a, int b, double mu) {
  const int n = static_cast<int>(bodies.size());
  if (friction_.size() != static_cast<size_t>(n) * n) friction_.assign(static_cast<size_t>(n) * n, params.default_friction);
  friction_[static_cast<size_t>(a) * n + b] = mu;
  friction_[static_cast<size_t>(b) * n + a] = mu;
}

bool World::CanTouch(int a, int b) const {
  const Body& ba = bodies[a];
  const Body& bb = bodies[b];
  if (ba.finger >= 0 && ba.finger == bb.finger) return false;
  return no_touch_.empty() || !no_touch_[static_cast<size_t>(a) * bodies.size() + b];
}

void World::SetCanTouch(int a, int b, bool can) {
  const size_t n = bodies.size();
  if (no_touch_.size() != n * n) no_touch_.assign(n * n, 0);
  no_touch_[a * n + b] = no_touch_[b * n + a] = can ? 0 : 1;
}

void World::Finalize() {
  may_carry_ = false;  // a scene changed: its contacts are detected
  const int n = static_cast<int>(bodies.size());
  if (friction_.size() != static_cast<size_t>(n) * n) {
    std::vector<double> old = friction_;
    friction_.assign(static_cast<size_t>(n) * n, params.default_friction);
  }
  if (!no_touch_.empty() && no_touch_.size() != static_cast<size_t>(n) * n) no_touch_.clear();
  // articulations: 6 dof per free body, 4 per finger
  articulations.clear();
  int max_leaves = 1;
  for (int i = 0; i < n; ++i) {
    Body& b = bodies[i];
    b.articulation = -1;
    if (b.motion == EMotion::Free) {
      Articulation a;
      a.ndof = 6;
      a.body = i;
      b.articulation = static_cast<int>(articulations.size());
      articulations.push_back(a);
    }
    const int leaves = b.geometry.is_plane ? 0 : b.geometry.tree.num_leaves();
    max_leaves = std::max(max_leaves, leaves);
    b.u.assign(leaves, Vec3::Zero());
    b.u_free.assign(leaves, Vec3::Zero());
    b.u_acc.assign(leaves, Vec3::Zero());
    b.u_acc_kept.assign(leaves, Vec3::Zero());
    b.u_spread.assign(leaves, 0.0);
    b.ForgetSpreads();
    b.u_changed.assign(leaves, 0);
    b.live.clear();
    b.live.reserve(leaves);
    b.live_mark.assign(leaves, 0);
    b.source.assign(leaves, 0);
    b.inf_slot.assign(leaves, -1);
    b.pose_prev = b.pose;
    // a scene change wakes everything
    b.asleep = false;
    b.rest_time = 0.0;
    b.contact_count = b.contact_count_prev = 0;
    b.pose_detected = b.sleep_pose = b.pose;
    b.core_radius = b.geometry.is_plane ? 0.0 : CoreRadius(b.geometry);
  }
  if (hand.carrier >= 0) hand.pose = bodies[hand.carrier].pose * hand.carrier_offset;
  for (size_t f = 0; f < hand.fingers.size(); ++f) {
    Finger& fg = hand.fingers[f];
    Articulation a;
    a.ndof = 4;
    a.finger = static_cast<int>(f);
    a.body = fg.body;
    fg.articulation = static_cast<int>(articulations.size());
    if (fg.body >= 0) {
      bodies[fg.body].articulation = fg.articulation;
      bodies[fg.body].finger = static_cast<int>(f);
      bodies[fg.body].motion = EMotion::Fingertip;
    }
    for (int l = 0; l < 3; ++l) {
      if (fg.segment_body[l] < 0) continue;
      Body& sb = bodies[fg.segment_body[l]];
      sb.articulation = fg.articulation;
      sb.finger = static_cast<int>(f);
      sb.finger_link = l + 1;
      sb.motion = EMotion::Fingertip;
    }
    articulations.push_back(a);
    fg.q_prev = fg.q;
    fg.kin = FingerForward(fg.model, hand.pose, fg.q);
    ForEachCarried(fg, fg.kin, [&](int body, const Pose& p) { bodies[body].pose = bodies[body].pose_prev = p; });
  }
  hand.pose_prev = hand.pose;

  // buffers: nothing grows during a step below these capacities
  contacts.Reserve(params.max_contacts);
  rows.reserve(params.max_contacts);
  collision_scratch.Reserve(max_leaves, 16 * params.max_contacts);
  max_leaves_ = max_leaves;
  UseRunner(runner_);
  // leaf-pair caches of the pairs of trees (their lists take their capacity the
  // first time the pair is traversed)
  pair_caches.clear();
  pair_caches.resize(static_cast<size_t>(n) * n);
  size_t reserved = 0;  // bytes of the caches' first capacity reserved here
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const Body& a = bodies[i];
      const Body& b = bodies[j];
      if (a.geometry.is_plane || b.geometry.is_plane) continue;
      const size_t all = static_cast<size_t>(a.geometry.tree.num_leaves()) * b.geometry.tree.num_leaves();
      PairCache& c = pair_caches[static_cast<size_t>(i) * n + j];
      c.limit = std::min(all, static_cast<size_t>(4) * params.max_contacts);
      c.wide_limit = std::min(all, static_cast<size_t>(8) * params.max_contacts);
      // the pairs that can touch get their lists' first memory now, while it fits a
      // budget (a pile of boxes has thousands of pairs: those reserve at their first
      // traversal); a step in which a pair first comes near then allocates nothing
      const size_t nodes = std::max(a.geometry.tree.nodes().size(), b.geometry.tree.nodes().size());
      const bool can_move = a.articulation >= 0 || b.articulation >= 0;
      if (can_move && CanTouch(i, j) && reserved + PairCache::StartBytes(nodes) <= kPairCacheBudget) {
        c.ReserveStart(nodes);
        reserved += PairCache::StartBytes(nodes);
      }
    }
  warm_prev.reserve(params.max_contacts);
  warm_next.reserve(params.max_contacts);
  // joint-limit rows: two ends of four joints per finger at most
  const int max_limits = 8 * static_cast<int>(hand.fingers.size());
  limit_rows.clear();
  limit_rows.reserve(max_limits);
  limit_warm.assign(max_limits, 0.0);
  solve_r.reserve(params.max_contacts + max_limits);
  push_keep.reserve(params.max_contacts + max_limits);
  // merged influences: a few dozen control points per deformable contact side;
  // grown (once) by a scene with wider influences, never in the steady state
  side_inf_idx.reserve(static_cast<size_t>(64) * params.max_contacts);
  side_inf_phi.reserve(static_cast<size_t>(64) * params.max_contacts);
  rows_prev.reserve(params.max_contacts);
  side_jacobians.reserve(static_cast<size_t>(2) * params.max_contacts);  // two finger sides at most
  rows_prev_index.Reserve(params.max_contacts);
  warm_index.Reserve(params.max_contacts);
  side_inf_idx_prev.reserve(static_cast<size_t>(64) * params.max_contacts);
  side_inf_phi_prev.reserve(static_cast<size_t>(64) * params.max_contacts);
  gs_scratch.Reserve(params.max_contacts + max_limits, params.solver.anderson_depth);
  contacts_prev.reserve(params.max_contacts);
  sleep_set.assign(n, 0);
  sleep_gravity = params.gravity;
}

void World::UseRunner(TaskRunner* runner) {
  runner_ = runner;
  if (!runner || runner->threads() < 2) {
    lanes.clear();
    return;
  }
  // every lane may have to hold the step's contacts: one pair can give them all
  lanes.resize(static_cast<size_t>(runner->threads()));
  for (CollisionLane& lane : lanes) {
    lane.scratch.Reserve(max_leaves_, 16 * params.max_contacts);
    lane.contacts.Reserve(params.max_contacts);
  }
  const size_t n = bodies.size();
  pair_tasks.reserve(n * (n - 1) / 2 + 1);
  task_order.reserve(n * (n - 1) / 2 + 1);
}

double World::step_budget_s() const {
  const double budget = params.step_time_budget_s;
  if (!profile.contacts_carried || !(budget > 0.0)) return budget;
  // the steps since the last detection, this one included, at the share each on average
  return std::min(budget, std::max(1e-9, params.carry_contacts_after_s * (carried_in_row_ + 2) - since_detection_s_));
}

// Whether this step may carry the last step's contacts: the steps since the last
// detection ran past their share of time (WorldParams::carry_contacts_after_s)
bool World::CarriesContacts() const {
  const double share = params.carry_contacts_after_s;
  return share > 0.0 && may_carry_ && carried_in_row_ < kMaxCarriedSteps &&
         since_detection_s_ > share * (carried_in_row_ + 1);
}

void World::Step() {
  const FlushSubnormals flush;  // core/float_mode.h: decaying motions must not slow the step down
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  step_started_ = t0;
  profile = StepProfile{};
  const bool carry = carrying_ = CarriesContacts();
  // the pairs will go to the runner's threads (collision_detection.cpp): wake them now,
  // while free motion runs
  if (!carry && runner_ && !lanes.empty() && last_pairs_s_ >= params.lanes_from_s && last_pairs_traversed_ >= 2)
    runner_->Expect();
  FreeMotion(*this);
  const auto t1 = Clock::now();
  WakeSleepingBodies(*this);
  DetectCollisions(*this);
  for (Body& b : bodies) b.pose_detected = b.pose;
  BuildContactSpace(*this);
  AllowStartingOverlaps(*this);
  SolveContacts(*this);
  PushOutOverlaps(*this);
  const auto t2 = Clock::now();
  ConstrainedMotion(*this);
  UpdateSleep(*this);
  const auto t3 = Clock::now();
  profile.free_motion = std::chrono::duration<double>(t1 - t0).count();
  profile.constrained_motion = std::chrono::duration<double>(t3 - t2).count();
  last_constrained_motion_s_ = profile.constrained_motion;
  profile.total = std::chrono::duration<double>(t3 - t0).count();
  carrying_ = false;
  const bool carried = profile.contacts_carried;
  carried_in_row_ = carried ? carried_in_row_ + 1 : 0;
  since_detection_s_ = (carried ? since_detection_s_ : 0.0) + profile.total;
  may_carry_ = !profile.rejected;
  profile.contacts = static_cast<int>(rows.size());
  time += params.dt;
  ++step_count;
  if (profile.rejected) ++rejected_steps;
  if (profile.rejected && profile.reject_reason == kPassThroughReason) ++pass_through_steps;
  if (!profile.converged) ++unconverged_steps;
  if (profile.budget_stopped) ++budget_stopped_steps;
  if (profile.solve_skipped) ++skipped_solves;
  if (profile.contacts_carried) ++carried_steps;
}

}  // namespace gs
