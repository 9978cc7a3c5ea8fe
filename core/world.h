// The World owns every body, the hand, the contacts and all step buffers. One
// time step follows the paper's Figure 1, one stage per file:
//
//   FreeMotion          free_motion.cpp         external forces, motors, drives,
//                                               relaxation of deformation
//   DetectCollisions    collision_detection.cpp refit, sphere-tree traversal,
//                                               MLS interpenetration (the body pairs
//                                               on a runner's threads: UseRunner)
//   BuildContactSpace   contact_space.cpp       frames, free gaps, Jacobians,
//                                               diagonal Delassus blocks, warm start
//     BuildJointLimitRows joint_limits.cpp      a finger joint near its limit: a
//                                               frictionless row in the same solve
//   SolveContacts       solver.cpp              block Gauss-Seidel, exact Coulomb
//   ConstrainedMotion   constrained_motion.cpp  apply forces: poses, joints,
//                                               control-point displacements
//
// The rigid part of the Delassus operator is never formed: each articulation
// (a free body: 6 dof; a finger: 4 joints) keeps its inverse mobility A^-1 and an
// accumulator dq = A^-1 sum J^T f, so a contact reads its gap from its bodies.
// The deformable part goes through the sparse influence of each body's control
// points. All buffers are sized by Finalize(); Step() does not allocate.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <string>

#include "core/body_geometry.h"
#include "core/collision.h"
#include "core/deformation.h"
#include "core/fc_problem.h"
#include "core/key_index.h"
#include "core/finger.h"
#include "core/nsgs.h"
#include "core/sampling.h"
#include "core/parallel.h"
#include "core/sphere_tree.h"
#include "core/types.h"

namespace gs {

enum class EMotion { Free, Fixed, Kinematic, Fingertip };
enum class EDynamics { Inertial, QuasiStatic };

/// A damped spring pulling a free body toward a target pose (virtual coupling),
/// gains in the target frame, plus a constant force in that frame.
struct Drive {
  bool enabled = false;
  Vec3 stiffness = Vec3::Zero();          ///< N/m per target axis
  Vec3 damping = Vec3::Zero();            ///< N s/m
  Vec3 angular_stiffness = Vec3::Zero();  ///< N m/rad
  Vec3 angular_damping = Vec3::Zero();    ///< N m s/rad
  Vec3 force = Vec3::Zero();              ///< N, target frame
  Vec3 torque = Vec3::Zero();             ///< N m, target frame (a feed-forward, like force)
  double max_force = 1e300;               ///< clamp of the spring force (N)
  Pose target;
};

struct Body {
  std::string name;
  EMotion motion = EMotion::Free;
  EDynamics dynamics = EDynamics::Inertial;
  double mass = 0.0;                          ///< kg
  Mat3 inertia = Mat3::Zero();                ///< body-frame inertia (kg m^2)
  double linear_damping = 0.0;                ///< B, N s/m
  double angular_damping = 0.0;               ///< B, N m s/rad
  Pose pose, pose_prev;                       ///< current and start-of-step pose
  Vec3 velocity = Vec3::Zero(), angular_velocity = Vec3::Zero();
  Drive drive;
  BodyGeometry geometry;
  DeformableModel deform;
  std::vector<Vec3> u;        ///< control-point displacements (rest frame, m)
  std::vector<Vec3> u_free;   ///< this step's free displacements
  std::vector<Vec3> u_acc;    ///< displacement from this step's contact forces
  /// steps left (at most) in which this body works off the overlap it started the scene
  /// with, pushed out without speed (core/push_out.cpp, CountPlacementSteps)
  int placement_steps = 0;
  bool placement_overlap = false;  ///< scratch of CountPlacementSteps: a row of this body starts overlapping
  std::vector<Vec3> u_acc_kept;  ///< the step solve's u_acc, kept while PushOutOverlaps solves the push
  std::vector<double> u_spread;
  /// u_spread's bound (constrained_motion.cpp, UpdateSpreads): each control point's
  /// spread as last measured, and spread_slack (twice the sum over the steps of the
  /// body's largest displacement change) at that time; -inf: measure at the next change
  std::vector<double> spread_base, spread_mark;
  double spread_slack = 0.0;
  std::vector<uint8_t> u_changed;
  /// The control points whose displacement the step integrates (free motion's
  /// relaxation, constrained motion's eq. 7): every point a contact force can have
  /// reached since Finalize, i.e. the influence of every control point a contact has
  /// stood on (`source`). The others are exactly at rest (u = u_free = u_acc = 0)
  /// and stay so without being visited: a grasp pays for the regions it touches, not
  /// for the whole body. Points are never dropped (a contact kept from the last step
  /// may still push them); Finalize empties the set and WakeAll fills it.
  std::vector<int> live;
  std::vector<uint8_t> live_mark;  ///< 1 for the points in `live`
  std::vector<uint8_t> source;     ///< 1 for control points whose influence is in `live`
  /// Puts control point j's influence into `live` (once per point).
  void AddSource(int j) {
    if (source[j]) return;
    source[j] = 1;
    const int* idx;
    const double* phi;
    const int m = deform.Influence(j, &idx, &phi);
    for (int k = 0; k < m; ++k)
      if (!live_mark[idx[k]]) {
        live_mark[idx[k]] = 1;
        live.push_back(idx[k]);
      }
  }
  /// Every spread measured again at its next change (after u was written by hand).
  void ForgetSpreads() {
    spread_base.assign(u.size(), 0.0);
    spread_mark.assign(u.size(), -std::numeric_limits<double>::infinity());
    spread_slack = 0.0;
  }
  /// Every control point live (after u was written by hand).
  void AllLive() {
    ForgetSpreads();
    live.resize(u.size());
    for (size_t j = 0; j < u.size(); ++j) live[j] = static_cast<int>(j);
    std::fill(live_mark.begin(), live_mark.end(), 1);
    std::fill(source.begin(), source.end(), 1);
  }
  std::vector<int> inf_slot;  ///< contact-space scratch: slot of a control point in a merged influence, -1
  bool emits_contacts = true; ///< false: one-pass contact, only other bodies' control points touch this one
  int finger = -1;            ///< for a body a finger carries (its fingertip or a segment), that finger
  int finger_link = 3;        ///< and the link that carries it (1 proximal .. 3 distal): joints 0..finger_link move it
  int articulation = -1;      ///< index into World::articulations, -1 when it has no dofs
  // sleep (SleepParams): a free body at rest skips collision detection
  bool asleep = false;
  double rest_time = 0.0;     ///< s spent slower than the sleep thresholds with the same contact count
  int contact_count = 0, contact_count_prev = 0;  ///< contacts it is in, this step and the last
  Pose sleep_pose;            ///< pose when it fell asleep (moving away from it wakes it)
  Drive sleep_drive;          ///< drive when it fell asleep (a change wakes it)
  Pose pose_detected;         ///< pose at the last collision detection (reused contacts move from there)
  /// radius of a ball about the body origin that lies inside the rest surface (m);
  /// 0 when the origin is not inside it (the pass-through check skips the body)
  double core_radius = 0.0;
  CollisionShape Shape() const;
};

struct Finger {
  std::string name;
  FingerModel model;
  Vec4 q = Vec4::Zero(), q_prev = Vec4::Zero(), q_target = Vec4::Zero();
  double motor_stiffness = 1.0;  ///< N m/rad
  double motor_damping = 0.0;    ///< N m s/rad
  double joint_damping = 0.0;    ///< B of the quasi-static model (N m s/rad)
  int body = -1;                 ///< the fingertip body
  /// Segment bodies carried by the links (a whole hand's phalanges; -1: none):
  /// segment_body[l] rides on link l + 1 at pose link * segment_offset[l]. A segment
  /// with its Drive enabled pulls the finger through that damped spring, mapped to
  /// the joints by the link's Jacobian (core/free_motion.cpp), as the motors do.
  std::array<int, 3> segment_body{-1, -1, -1};
  std::array<Pose, 3> segment_offset;
  int articulation = -1;
  FingerKinematics kin;          ///< at the free-motion configuration during a step
};

struct Hand {
  Pose pose, pose_prev;
  std::vector<Finger> fingers;
  /// A free body that carries the hand (a whole hand's palm; -1: the hand pose is
  /// prescribed): each step starts with pose = carrier's pose * carrier_offset, so
  /// the fingers ride on the palm with one step of lag, and their contact forces do
  /// not push the palm (docs/solver.md, "Articulated whole hand").
  int carrier = -1;
  Pose carrier_offset;
};

/// Calls fn(body, pose) for every body finger f carries at kinematics k: its
/// fingertip (link 3, at k.tip) and its segments (at their link * offset).
template <class Fn>
void ForEachCarried(const Finger& f, const FingerKinematics& k, Fn&& fn) {
  if (f.body >= 0) fn(f.body, k.tip);
  for (int l = 0; l < 3; ++l)
    if (f.segment_body[l] >= 0) fn(f.segment_body[l], k.link[l] * f.segment_offset[l]);
}

/// The generalized coordinates of a free body or a finger, as the solver sees them.
struct Articulation {
  int ndof = 0;
  int body = -1;
  int finger = -1;
  Mat6 a_inv = Mat6::Zero();  ///< inverse generalized mobility (dof units per N)
  Vec6 dq_free = Vec6::Zero();
  Vec6 dq = Vec6::Zero();     ///< accumulated A^-1 J^T f of the current forces
  /// the body's motion without the push-out of starting overlaps (PushOutOverlaps):
  /// its end-of-step velocity is (dq_free + dq_velocity) / dt in such a step
  Vec6 dq_velocity = Vec6::Zero();
};

/// Eq. 8 interpolation of one contact point over its body's control points.
struct ContactSide {
  static constexpr int kMaxWeights = 6;
  int body = -1;
  int articulation = -1;
  int count = 0;
  int idx[kMaxWeights];
  double w[kMaxWeights];
  /// A free body's side: the lever arm from the body's centre to the material point
  /// (world, m). Its rows H = sign * frame * J, with J = [I, -[lever]x], are applied in
  /// place (core/contact_jacobian.h): 24 bytes instead of H and A^-1 H^T's 288
  /// (read only where set: not zeroed, rows are built in place every step). A
  /// deformable side moves the gap and slip by sign * frame * R d for a displacement d
  /// of its control points (rest frame), the force in the rest frame being
  /// sign * R^T frame^T dr: R is the body's, read at the solve.
  Vec3 lever;
  /// A free body's side: (arm x n), arm from the material point to where the rest
  /// surfaces touch (Contact::touch, world): the normal force turns the body about
  /// that point, its row is n . (v + w x (lever + arm)). Zero without a touch offset.
  Vec3 spin;
  /// A finger's side: its H and A^-1 H^T in World::side_jacobians (-1: none)
  int jacobian = -1;
  double sign = 1.0;
  /// the side's merged influence on its body's control points: a force F at the
  /// contact point moves control point m by phi_m F (eq. 8 weights folded into eq. 13),
  /// entries [inf_begin, inf_begin + inf_count) of World::side_inf_idx / side_inf_phi;
  /// a side standing on one control point (weight 1: the query side of every contact)
  /// reads that point's influence in its body's model instead (inf_begin = -1)
  int inf_begin = 0, inf_count = 0;
  /// where the solver reads the merged influence (set at the end of the contact space,
  /// valid until the next one)
  const int* inf_idx = nullptr;
  const double* inf_phi = nullptr;
  double w_deform = 0.0;  ///< this side's share of W_deform,cc (m/N, isotropic)
  Vec3 weights_at = Vec3::Zero();  ///< rest-frame point at which the eq. 8 weights were evaluated
};

/// The rows of a finger's contact side: h = sign * frame * J (its last columns zero
/// past the finger's joints) and g = A^-1 h^T (a force change dr moves the
/// finger's accumulator by g dr).
struct SideJacobian {
  Eigen::Matrix<double, 3, 6> h;
  Eigen::Matrix<double, 6, 3> g;
};

/// One row block of the contact space (normal first, then the two tangents).
struct ContactRow {
  /// user-provided, so that rows.emplace_back() does not zero the whole row before
  /// BuildContactSpace sets every member (value-initialisation otherwise zero-fills)
  ContactRow() {}
  Contact contact;
  Mat3 frame;       ///< rows n, t1, t2 (world)
  Vec3 world_point; ///< contact point (world, m)
  ContactSide side[2];
  Mat3 w_diag;      ///< W_cc (m/N)
  Vec3 q;           ///< free gap (normal) and free slip (tangents) (m)
  Vec3 r;           ///< force (N) in the frame
  double mu = 0.0;
  double gap_start = 0.0;  ///< normal gap at the start of the step, deformation included (m)
  double held_back = 0.0;  ///< part of an overlap present at the step's start left for later steps (m), see max_push_out_speed
  int prev = -1;           ///< the same contact (key) in the last step's rows, when reuse is on
};

/// A finger's joint limit as a unilateral row of the solve (core/joint_limits.h):
/// Signorini on the joint's distance to the limit, solved with the contacts. In the
/// solver it is a frictionless row (mu = 0) whose normal is the joint's coordinate
/// scaled by `lever`: velocity sign * lever * dq_j (m), force r (N), applied to the
/// joint as the torque sign * lever * r. Its tangents carry nothing (zero W rows and
/// columns; mu = 0 keeps their forces at zero).
struct LimitRow {
  int slot = -1;          ///< finger * 8 + joint * 2 + end: the row's key (warm start)
  int finger = -1, joint = -1, articulation = -1;
  double sign = 1.0;      ///< +1: the lower limit (pushes q up); -1: the upper
  double lever = 1.0;     ///< m: the finger's length beyond the joint (row units: metres of arc)
  double w = 0.0;         ///< W_jj = lever^2 (A^-1)_jj (m/N)
  double q = 0.0;         ///< free gap: sign * lever * (q_prev + dq_free - limit), + held_back (m)
  double r = 0.0;         ///< force (N); the joint torque is sign * lever * r (N m)
  double gap_start = 0.0; ///< sign * lever * (q_prev - limit) (m)
  double held_back = 0.0; ///< part of a violation present at the step's start left for later steps (m)
  /// the generalized torque on the joint (N m, signed like q)
  double Torque() const { return sign * lever * r; }
};

/// Bodies at rest skip collision detection (docs/skip.md, "Bodies at rest"). A
/// free body slower than both thresholds for `time` seconds, in as many contacts
/// each step, falls asleep once no awake moving body's bounding sphere reaches
/// it. A sleeping body is still integrated and solved like any other: only its
/// pairs against other sleeping bodies or bodies that do not move skip collision
/// detection, reusing the last step's contacts moved rigidly with the two poses.
/// It wakes when it gets faster than a threshold or its contact count changes,
/// when an awake moving body's bounding sphere reaches it, when any point of it
/// has moved more than `max_drift` from where it fell asleep, when its drive
/// (target, gains, force) or gravity changes, when a step is rejected, and on
/// Finalize (a scene change) or World::WakeAll.
struct SleepParams {
  bool enabled = true;
  double linear_velocity = 1e-3;   ///< m/s
  double angular_velocity = 1e-2;  ///< rad/s
  double time = 0.1;               ///< s at rest before falling asleep
  double max_drift = 2e-5;         ///< m: farthest a point may move from where the body fell asleep
};

/// The step's default sweep cap (WorldParams::solver.max_iterations). Dense contacts
/// under wide skins need hundreds of sweeps (the whole hand at the paper's densities:
/// up to 650 in its lift, 146 with Anderson acceleration); a live loop's time budget
/// stops a solve before its cap.
constexpr int kStepSweepCap = 1000;
/// Steps in a row that may carry the last contacts (WorldParams::carry_contacts_after_s).
constexpr int kMaxCarriedSteps = 2;
/// The step's Anderson acceleration depth (NsgsParams::anderson_depth; docs/solver.md,
/// "Anderson acceleration in the step"): the whole hand's closing and lift at the
/// paper's densities took 105,008 sweeps without it, 31,592 with it.
constexpr int kStepAndersonDepth = 5;

struct WorldParams {
  double dt = 1e-3;
  Vec3 gravity = Vec3(0, 0, -9.81);
  CollisionParams collision;
  int refit_stop_level = 3;
  /// The step stops on the scaled measure (core/nsgs.h; gap_scale is set per step
  /// to |g| dt^2): the tolerance bounds each contact's velocity error by tolerance |g| dt.
  NsgsParams solver = [] {
    NsgsParams p;
    p.measure = EStopMeasure::Scaled;
    p.max_iterations = kStepSweepCap;
    p.anderson_depth = kStepAndersonDepth;
    return p;
  }();
  int max_contacts = 8192;
  double default_friction = 0.8;
  /// m/s: an overlap already present at the start of a step (a body placed inside
  /// another, a teleport) is pushed out at most this fast, so that it cannot launch
  /// the body (a 4 mm overlap removed in one 1 ms step would leave at 4 m/s).
  /// Overlap made by the step's own free motion is always removed at once.
  double max_push_out_speed = 0.1;
  /// A body placed overlapping another is pushed out of it without being given the
  /// push's speed: for the steps it takes to work off the overlap it starts the scene
  /// with, its poses come from a frictionless push added to the step's motion and its
  /// velocities from a solve that keeps the overlap from deepening (core/push_out.cpp).
  /// Without this a box set on a table at its half height (0.125 mm inside its MLS
  /// surface) was pushed out at 0.1 m/s and jumped 0.5 mm. false: the speed is kept.
  bool push_out_keeps_no_speed = true;
  /// A step in which a body's centre passes into another body is rejected (the last
  /// state kept, FindPassThrough) so that a passing glitch, a tracker's bad frame,
  /// cannot throw a body through another. Each retry is the same step again while
  /// nothing changes; after this many rejected steps in a row for the same pair the
  /// step is let through (counted in World::pass_throughs_let): a tracked hand pulled
  /// through an object goes on instead of freezing the world for as long as the
  /// pull lasts (it stayed frozen after the tracked hand had left). 0: never reject.
  int pass_through_retries = 50;
  /// Reuse the merged influence and W_deform term of a contact side that is the
  /// same as in the last step (same contact key, same interpolation weights):
  /// exact, the copied values are the ones that would be recomputed. Off only to
  /// measure what it saves (bench skip).
  bool reuse_contact_space = true;
  SleepParams sleep;
  /// With reuse on, a contact side on a deformable body keeps the last step's eq. 8
  /// weights (and so its merged influence and W_deform term) while its surface anchor
  /// stays within this fraction of the body's control-point spacing of the point the
  /// weights were evaluated at (measured from that point, so drift cannot accumulate).
  /// Resting contacts drift by ~1e-9 m per step (paper grasp), far below the MLS
  /// projection's own tolerance (1e-3 bandwidth, ~3e-6 m). 0: bitwise-equal anchors only.
  double reuse_anchor_tolerance = 1e-4;
  /// Wall-clock budget of a whole step (s; 0: none, the default). The solver then
  /// stops sweeping when the rest of the budget would not hold another sweep (see
  /// NsgsParams::time_budget_s); such a step counts as unconverged and as a budget
  /// stop. When the stages before the solve have left less than one sweep (what a
  /// sweep of the last solve took), the step does not sweep at all: its forces are
  /// the warm start (the last step's forces, in the cones), and it counts as a
  /// skipped solve (StepProfile::solve_skipped), when budget_may_skip_solve is on. Never two steps in a row, so a
  /// machine that stays slow still solves every other step, and never when more
  /// than 5 % of the contacts are new (no last force to keep: a landing). Set by loops paced by
  /// the wall clock (live sets it per step from its deadline); a step's result then
  /// depends on the machine's speed.
  double step_time_budget_s = 0.0;
  /// Off by default: a step out of time still sweeps once (late rather than
  /// unsolved). The sweep after a skipped one starts from older forces, and on the
  /// paper's grasp reached errors up to 0.13 where one-sweep steps stay below 1e-3.
  bool budget_may_skip_solve = false;
  /// Steps short of time skip collision detection where little moved (s; 0: never,
  /// the default): while the steps since the last detection, that one included, took
  /// longer than this each on average, in the next one each body pair that has hardly
  /// slid (carry_max_slide_m) carries the last step's contacts, moved with the
  /// bodies as the contacts of a sleeping pair are (MoveWithBodies: the gap follows
  /// the two anchors along the normal, the normal turns with body[1]), and the step
  /// counts as carried (StepProfile::contacts_carried). At most kMaxCarriedSteps in
  /// a row, never after a rejected step, a scene change or WakeAll, so that contacts
  /// are detected at least every third step. No contact is missed (the bodies moved
  /// less than the contact threshold against each other); what a carried contact
  /// gets wrong is the gap's second-order term, curvature x (tangential motion)^2 / 2,
  /// and the normal's turn over the slide. Set by loops paced by the wall clock
  /// (live: the step budget's share of a timestep), where a step that detects and the
  /// ones that carry fit in their timesteps when detecting ones do not
  /// (docs/collision.md, "Carried contacts"). A step's result then depends on the
  /// machine's speed.
  double carry_contacts_after_s = 0.0;
  /// In a step that may carry contacts, a body pair carries them only while each
  /// contact's points have slid against the other body (across the contact's normal)
  /// by at most this much (m) since the last step, and no point of either body has
  /// moved against the other by the contact threshold
  /// (core/carried_contacts.cpp): where the forces act stays within this of where
  /// detection would put them (0.25 % of the paper box's control-point spacing).
  double carry_max_slide_m = 5e-6;
  /// A step whose Gauss-Seidel ends unconverged continues with the semi-smooth
  /// Newton method on its assembled Delassus matrix (core/solver.cpp
  /// ContinueWithNewton), at most this many Newton steps (0: never), when it has
  /// no time budget.
  int newton_max_steps = 50;
  /// ... and at most as many steps as fit in this much work, counted as a dense LU
  /// factorisation's (2/3) m^3 multiply-adds per step, m = 3 x contacts: 50 steps up
  /// to about 100 contacts, 16 at 150, 2 at 300, none from 382 on (a 951-contact step of a
  /// replay had taken 4-5 s). The same in every run: no machine's speed enters it.
  double newton_max_work = 1e9;
  /// rad: a finger joint whose distance to a limit, at the step's start or after its
  /// free motion, is at most this much gets a limit row in the step's solve (the
  /// joint-limit analogue of the contact threshold). A contact response that moves
  /// a joint further than this in one step past a limit it did not see is pushed
  /// back by the next step's row (docs/solver.md, "Joint limits").
  double joint_limit_margin = 0.05;
  /// With a runner (World::UseRunner), the body pairs of a step are detected on its
  /// threads when the steps' pairs take at least this long (s, summed over threads;
  /// CollisionStats traverse_s + project_s, the median of the last nine steps):
  /// below it waking a sleeping worker costs about what it saves (the paper grasp's
  /// pairs take 0.09 ms, the whole hand's at the paper's densities 0.36 ms). The
  /// results are the same either way.
  double lanes_from_s = 1.5e-4;
};

/// Work done by the last step, counted where it is done: what a scene does not
/// need reads zero here (docs/skip.md).
struct StepWork {
  int refit_trees = 0;        ///< trees refit (a deformed body whose control points moved)
  int refit_nodes = 0;        ///< tree nodes recomputed or inflated by refit
  int body_pairs = 0;         ///< body pairs that both can move or deform (candidates of the broad phase)
  int pair_tests = 0;         ///< bounding-sphere tests of the broad phase (one per candidate pair)
  int pairs_traversed = 0;    ///< body pairs whose trees were traversed (bounding spheres overlap)
  int pairs_clear = 0;        ///< body pairs not detected: proven apart by more than their motion since (PairStaysClear)
  int pairs_from_cache = 0;   ///< of those, pairs of trees served by their leaf-pair cache (no descent)
  int node_tests = 0;         ///< sphere tests of collision detection (descents and cached lists)
  int pairs_on_lanes = 0;     ///< of pairs_traversed, pairs detected as tasks on the runner's threads (World::UseRunner)
  int w_blocks_built = 0;     ///< diagonal Delassus blocks W_cc computed
  int w_deform_sides = 0;     ///< contact sides whose W_deform term and merged influence were built
  int w_deform_reused = 0;    ///< of those, merged influences copied from the last step (same contact, same weights)
  int w_deform_direct = 0;    ///< of those, sides on one control point, reading its influence in place (nothing merged)
  int weights_reused = 0;     ///< eq. 8 interpolations kept from the last step (anchor within reuse_anchor_tolerance)
  int warm_started = 0;       ///< contacts whose solve starts from the last step's force of the same contact
  int local_solves_3d = 0;    ///< local Coulomb solves (normal and tangents)
  int local_solves_normal = 0;///< normal-only local solves (every contact frictionless)
  int propagations = 0;       ///< control-point updates u += phi F in the solver (displacement propagation)
  int deformed_points = 0;    ///< control points integrated by constrained motion (eq. 7)
  int bodies_asleep = 0;      ///< free bodies asleep during this step's collision detection
  int pairs_asleep = 0;       ///< candidate pairs not tested (both asleep, or asleep against a body that does not move)
  int contacts_reused = 0;    ///< contacts of those pairs carried over from the last step
  int pairs_carried = 0;      ///< pairs that kept their last contacts in a step short of time (WorldParams::carry_contacts_after_s)
  int contacts_carried = 0;   ///< their contacts, carried over from the last step
  int limit_rows = 0;         ///< finger joint-limit rows in the solve (LimitRow)
  int push_out_splits = 0;    ///< frictionless push-out solves of starting overlaps (PushOutOverlaps)
};

/// Per-stage times of the last step (s), in the layout of the paper's Figures 6 and 7.
struct StepProfile {
  double free_motion = 0, traverse = 0, interpenetration = 0, refit = 0;
  double fill_w_rigid = 0, fill_w_deform = 0, solve = 0, constrained_motion = 0, total = 0;
  /// wall time of collision detection (refit, traverse and projections, s). With the
  /// pairs on the runner's threads, `traverse` and `interpenetration` are the threads'
  /// sums and can add up to more than this.
  double detect = 0;
  int contacts = 0;
  int iterations = 0;
  int newton_steps = 0;  ///< Newton steps after an unconverged Gauss-Seidel (WorldParams::newton_max_steps)
  /// the solver's stopping measure (params.solver.measure: the scaled one by default)
  /// of the step's forces, an upper bound of it (residual_bounded) or its estimate
  /// (residual_estimated); converged means residual <= params.solver.tolerance
  double residual = 0.0;
  double residual_siconos = 0.0;  ///< Siconos' fc3d measure of the same forces (bound / estimate likewise)
  bool residual_bounded = false;  ///< the solve converged on a bound of the error (NsgsParams::accept_error_bound)
  bool residual_estimated = false;  ///< the solve ran out of its time budget: the residual is the last sweep's estimate
  bool converged = true;
  bool budget_stopped = false;  ///< the solve ended at WorldParams::step_time_budget_s, unconverged
  /// no time was left for a sweep (WorldParams::step_time_budget_s): the forces are
  /// the warm start, `iterations` is 0, and `residual` (0) was not measured
  bool solve_skipped = false;
  /// some body pairs were not detected: they carried the last step's contacts
  /// (WorldParams::carry_contacts_after_s; StepWork::pairs_carried)
  bool contacts_carried = false;
  /// a body working off the overlap it was placed with was pushed out by a frictionless
  /// solve, moved without being given its speed (PushOutOverlaps;
  /// WorldParams::push_out_keeps_no_speed)
  bool push_out_split = false;
  bool rejected = false;  ///< the step produced a non-finite value and was undone
  const char* reject_reason = "";  ///< the first stage that saw a non-finite value (static text)
  CollisionStats collision;
  StepWork work;
};

/// A body that passed through another during a step (FindPassThrough): the centre
/// of one came inside the other's core ball (Body::core_radius), or below a plane.
struct PassThrough {
  int body = -1, other = -1;  ///< `body` moved through `other` (a plane or any body)
  int64_t step = 0;           ///< the step's number (World::step_count after it)
  double time = 0.0;          ///< simulated time at the step's end (s)
  double distance = 0.0;      ///< closest approach of the centres, or the centre's height over the plane (m)
  double core = 0.0;          ///< the core radius the centre entered (m; 0 for a plane)
};

class World {
 public:
  WorldParams params;
  std::vector<Body> bodies;
  Hand hand;
  std::vector<Articulation> articulations;
  std::vector<ContactRow> rows;
  /// the joint-limit rows of the step, solved after rows (solver index rows.size() + k)
  std::vector<LimitRow> limit_rows;
  ContactBuffer contacts;
  StepProfile profile;
  double time = 0.0;
  int64_t step_count = 0;
  int64_t rejected_steps = 0;
  int64_t unconverged_steps = 0;
  int64_t budget_stopped_steps = 0;  ///< of the unconverged steps, those ended by the time budget
  int64_t skipped_solves = 0;        ///< of those, steps that did not sweep (StepProfile::solve_skipped)
  int64_t carried_steps = 0;         ///< steps in which pairs carried their contacts (StepProfile::contacts_carried)
  int64_t pass_through_steps = 0;    ///< of the rejected steps, those where a body passed through another
  int64_t pass_throughs_let = 0;     ///< steps accepted with a pass-through after pass_through_retries rejections
  int pass_through_streak = 0;       ///< rejected steps in a row for last_pass_through's pair
  PassThrough last_pass_through;     ///< the last of them (rejected or let through)

  /// Friction coefficient of a body pair (default unless set).
  double Friction(int a, int b) const;
  void SetFriction(int a, int b, double mu);
  /// Whether bodies a and b may touch: false for two fingertips of one finger
  /// (Body::finger) and for a pair excluded by SetCanTouch (the segments of one
  /// tracked finger, of a hand without self contact). A pair that may not touch is
  /// left out of collision detection, the pass-through check and the starting-overlap check.
  bool CanTouch(int a, int b) const;
  /// Excludes (false) or readmits (true) the pair; call after the bodies are added
  /// (Finalize keeps the exclusions while the number of bodies stays the same).
  void SetCanTouch(int a, int b, bool can);

  /// Sizes every buffer and the articulations; call after adding bodies and fingers.
  void Finalize();
  /// Lets the step run its independent tasks (the body pairs' collision detection)
  /// on the runner's threads; null: all on the caller's. Sizes each thread's buffers
  /// (again at every Finalize). The results are the same, bit for bit, either way.
  void UseRunner(TaskRunner* runner);
  TaskRunner* runner() const { return runner_; }
  /// One time step of params.dt.
  void Step();
  /// Wakes every sleeping body (call after changing a body's state by hand:
  /// its pose, velocity, shape, its displacements u; drive and gravity changes are
  /// noticed). Every control point is integrated again from the next step (Body::live).
  void WakeAll();
  /// When the step in progress started, and how long the last step's constrained
  /// motion took (the solver's share of step_time_budget_s is computed from them).
  std::chrono::steady_clock::time_point step_started() const { return step_started_; }
  double last_constrained_motion_s() const { return last_constrained_motion_s_; }
  /// The step in progress's time budget (s; 0: none): params.step_time_budget_s, and
  /// once its pairs have carried contacts no more than keeps the steps since the last
  /// detection at params.carry_contacts_after_s each on average (the next detection
  /// gets back the time the detecting step overran by).
  double step_budget_s() const;

  // internals shared by the stages
  std::chrono::steady_clock::time_point step_started_{};
  double last_constrained_motion_s_ = 0.0;
  double last_sweep_s_ = 0.0;  ///< the last sweeping solve's time per sweep (warm start included)
  bool last_solve_skipped_ = false;
  /// the steps since the last detection, that one included: their own time (s) and
  /// how many carried (WorldParams::carry_contacts_after_s)
  double since_detection_s_ = 0.0;
  int carried_in_row_ = 0;
  bool carrying_ = false;       ///< the step in progress may carry contacts (CarriesContacts)
  size_t carry_cursor_ = 0;     ///< PairCarried's place in contacts_prev
  bool may_carry_ = false;  ///< the last step was not rejected, and nothing reset the contacts since
  bool CarriesContacts() const;
  std::vector<double> friction_;
  std::vector<uint8_t> no_touch_;  ///< 1 for the pairs SetCanTouch excluded, [a * bodies + b]; empty: none
  CollisionScratch collision_scratch;
  /// a body pair to detect in the step (collision_detection.cpp): asleep (its last
  /// contacts reused) or collided, as one task whose contacts land in a lane
  struct PairTask {
    int i = 0, j = 0;
    bool kept = false;     ///< its last contacts reused (asleep or carried), not detected
    bool carried = false;  ///< of those, carried in a step short of time
    int lane = 0, begin = 0, end = 0;  ///< where its contacts are
  };
  std::vector<PairTask> pair_tasks;
  std::vector<int> task_order;  ///< the collided tasks, larger first
  /// one runner thread's buffers for the pairs it detects
  struct CollisionLane {
    CollisionScratch scratch;
    ContactBuffer contacts;
    CollisionStats stats;
  };
  std::vector<CollisionLane> lanes;
  TaskRunner* runner_ = nullptr;
  int last_pairs_traversed_ = 0;  ///< the last step's StepWork::pairs_traversed (one pair: no task for a worker)
  double last_pairs_s_ = 0.0;  ///< the steps' pair work (CollisionStats traverse_s + project_s, every thread's): the median of the last kPairSamples steps
  static constexpr int kPairSamples = 9;
  std::array<double, kPairSamples> pair_samples_{};  ///< the last steps' pair work (s), a ring
  int pair_sample_next_ = 0;
  int max_leaves_ = 1;  ///< the most leaves of a body's tree (Finalize)
  std::vector<PairCache> pair_caches;  ///< leaf-pair caches of the tree pairs, [i * bodies + j] for i < j
  NsgsScratch gs_scratch;
  std::vector<std::pair<uint64_t, Vec3>> warm_prev, warm_next;  ///< previous step's world forces (key, force)
  KeyIndex warm_index;                ///< key -> index in warm_prev (built by the contact space)
  std::vector<double> limit_warm;     ///< last step's force (N) of each limit row slot (LimitRow::slot), 0 when inactive
  std::vector<Vec3> solve_r;
  /// PushOutOverlaps: the step solve's free gaps, forces and friction of every row
  /// while the push is solved (reserved by Finalize), and whether the step has one to do
  struct PushKeep {
    Vec3 q, r;
    double mu;
  };
  std::vector<PushKeep> push_keep;
  bool push_out_pending = false;
  std::vector<int> side_inf_idx;      ///< merged influences of the contact sides (see ContactSide)
  std::vector<double> side_inf_phi;
  std::vector<SideJacobian> side_jacobians;  ///< of the finger sides (see ContactSide::jacobian)
  // the last step's contact space, for reuse (params.reuse_contact_space)
  std::vector<ContactRow> rows_prev;
  std::vector<int> side_inf_idx_prev;
  std::vector<double> side_inf_phi_prev;
  KeyIndex rows_prev_index;           ///< key -> index in rows_prev
  // sleep: the last step's contacts (in pair order) and a cursor into them
  std::vector<Contact> contacts_prev;
  size_t reuse_cursor = 0;
  std::vector<uint8_t> sleep_set;  ///< scratch of UpdateSleep, one per body
  Vec3 sleep_gravity = Vec3::Zero();
};

/// Sleep, before collision detection: wakes the sleeping bodies that must wake
/// (see SleepParams) and keeps the last contacts for the ones that stay asleep.
void WakeSleepingBodies(World& w);
/// True when collision detection of bodies i and j can reuse the last contacts:
/// one is asleep and the other is asleep or does not move.
bool PairAsleep(const World& w, int i, int j);
/// Appends the last step's contacts of pair (i, j), moved with the two bodies'
/// poses since then (gap along the normal turned with body[1]).
void ReuseContacts(World& w, int i, int j, bool carried = false);
/// A contact found at the bodies' poses of the last detection (Body::pose_detected),
/// moved with them to their poses now: the gap follows the two anchors along the
/// normal, the normal turns with body[1].
void MoveWithBodies(const World& w, Contact* c);
/// In a step that carries contacts (WorldParams::carry_contacts_after_s), whether
/// pair (i, j), whose root spheres overlap, keeps its last contacts instead of being
/// detected (core/carried_contacts.cpp). Call in the pair loop's order.
bool PairCarried(World& w, int i, int j);
/// Sleep, at the end of a step: rest times, bodies that fall asleep or wake.
void UpdateSleep(World& w);

/// Everything needed to add a body to a world.
struct BodySpec {
  std::string name;
  ShapeDesc shape;
  bool is_plane = false;
  const TriangleMesh* mesh = nullptr;  ///< when set, sampled instead of `shape`
  GeometryOptions geometry;
  Pose pose;
  Vec3 velocity = Vec3::Zero();          ///< initial, world frame (m/s)
  Vec3 angular_velocity = Vec3::Zero();  ///< initial, world frame (rad/s)
  EMotion motion = EMotion::Free;
  EDynamics dynamics = EDynamics::Inertial;
  double mass = 0.0;
  Mat3 inertia = Mat3::Zero();  ///< body frame, about the origin (kg m^2); zero: SolidInertia(shape, mass)
  double linear_damping = 0.0, angular_damping = 0.0;
  DeformationParams deformation;
  Drive drive;
  bool emits_contacts = true;
};

/// Builds the body's geometry and deformation and appends it (call before Finalize).
/// Returns the new body's index, or -1 with *error set.
int AddBody(World& w, const BodySpec& spec, EGeometryError* error = nullptr);

/// The pose reached from `start` by the displacement (dx, dtheta) (world frame).
Pose AdvancePose(const Pose& start, const Vec6& dq);

/// Inertia of a solid of uniform density (body frame, about the centroid).
Mat3 SolidInertia(const ShapeDesc& shape, double mass);

// the stages, in order
void FreeMotion(World& w);
void DetectCollisions(World& w);
void BuildContactSpace(World& w);
/// The joint-limit rows of the step (core/joint_limits.cpp; called by BuildContactSpace).
void BuildJointLimitRows(World& w);
/// Keeps the step's limit forces by slot for the next warm start (called by ConstrainedMotion).
void KeepLimitForces(World& w);
/// may_skip: the step's time budget may keep the warm start without a sweep
/// (WorldParams::budget_may_skip_solve); PushOutOverlaps' solve always sweeps.
void SolveContacts(World& w, bool may_skip = true);
/// Before SolveContacts: the overlaps of the bodies still working off the one they
/// were placed with are allowed to stay (the rows' free gaps raised by them, held_back
/// all of them), so that the solve gives the forces and velocities without the push;
/// true when some row is so (core/push_out.cpp; WorldParams::push_out_keeps_no_speed).
bool AllowStartingOverlaps(World& w);
/// After SolveContacts: a frictionless normal-only solve removes what
/// max_push_out_speed allows of those overlaps, its motion added to the positions and
/// not to the velocities.
void PushOutOverlaps(World& w);
/// The scaled measure's gap for the step (NsgsParams::gap_scale): |g| dt^2
/// (9.81 m/s^2 when the scene has no gravity).
double StepGapScale(const WorldParams& wp);
/// Newton steps the step's continuation may take on n contacts: newton_max_steps,
/// and no more than newton_max_work allows at (2/3)(3n)^3 per step.
int NewtonStepsAllowed(const WorldParams& wp, int n);
void ConstrainedMotion(World& w);
/// Marks the step as rejected (undone by ConstrainedMotion); the first reason is kept.
void MarkRejected(World& w, const char* reason);
/// The reject reason of a step in which a body passed through another.
extern const char* const kPassThroughReason;

/// Radius of the largest ball about the body origin inside the sampled rest surface
/// (m): the distance to the nearest surface point when that point's normal faces away
/// from the origin, else 0 (the origin lies outside the surface).
double CoreRadius(const BodyGeometry& g);
/// Pass-through check of constrained motion, on the poses the step is about to
/// accept (Body::pose) against its start (pose_prev): true, with
/// w.last_pass_through set, when over the step (centres moving on straight lines)
/// the centre of a moving body entered the core ball of another body it can touch
/// (closer than the larger of the two core radii) or went below a plane. A pair
/// that starts that close is not counted again. No allocation; O(bodies^2).
bool FindPassThrough(World& w);

/// The last step's contact problem with W assembled explicitly, column by column
/// through the same matrix-free operator the solver uses (for export and checks:
/// it allocates and costs O(contacts x contacts sharing a body); Step calls it only
/// for the Newton continuation). Its rows are the contacts (w.rows, in order) then
/// the joint-limit rows (w.limit_rows: mu = 0, zero tangent rows and columns), as
/// the step solved them. `r`, when not null, receives the step's forces in the same order.
void AssembleContactProblem(World& w, FcProblem* p, Eigen::VectorXd* r = nullptr);

}  // namespace gs
