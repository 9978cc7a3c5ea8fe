// The step's guarantees: no allocation once warmed up, a step that would
// produce NaN or Inf is rejected with the previous state kept, and no subnormal
// number survives a step.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <algorithm>
#include <string>
#include <vector>
#include <new>

#include "core/float_mode.h"
#include "core/local_solver.h"
#include "core/world.h"
#include "soft_bodies.h"
#include "task_runners.h"

namespace {
std::atomic<long> g_allocations{0};
std::atomic<bool> g_counting{false};
}  // namespace

// counts every allocation of this test binary while g_counting is set
void* operator new(std::size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace gs {
namespace {

// a deformable ball resting on a plane, pushed sideways by a drive, and a second
// rigid free box on the plane: free, fixed, rigid and deformable paths all run
// (with `finger`, also a finger without fingertip whose motors pull two joints past
// their limits: the joint-limit rows run too)
void BuildScene(World& w, bool finger = false) {
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-7;
  w.params.solver.max_iterations = 200;
  test::AddPlane(w);
  BodySpec s = test::SoftBall(Vec3(0, 0, 0.0101));
  s.drive.enabled = true;
  s.drive.force = Vec3(0.05, 0, 0);
  AddBody(w, s);
  AddBody(w, test::SmallBox("box", Vec3(0.05, 0, 0.0102), 0.01));
  if (finger) {
    Finger f;
    f.model.link_lengths = {0.035, 0.025, 0.018};
    f.model.limits = {{{-0.6, 0.6}, {-0.2, 1.6}, {0.0, 1.8}, {0.0, 1.6}}};
    f.model.base = Pose::Translation(Vec3(0, 0.2, 0.2));
    f.q = Vec4(0.0, 1.5, 0.1, 0.5);
    f.q_target = Vec4(0.0, 2.0, -0.5, 0.5);
    w.hand.fingers.push_back(f);
  }
  w.Finalize();
}

// Allocations over `steps` steps of w. A step that Gauss-Seidel leaves unconverged
// continues with Newton on an assembled matrix (core/solver.cpp ContinueWithNewton),
// which allocates: those are not counted; every other step must not allocate.
struct Allocations {
  long count = 0;
  int checked = 0;  ///< steps counted (without Newton)
};
Allocations CountAllocations(World& w, int steps) {
  Allocations a;
  for (int i = 0; i < steps; ++i) {
    g_allocations = 0;
    g_counting = true;
    w.Step();
    g_counting = false;
    if (w.profile.newton_steps > 0) continue;
    a.count += g_allocations.load();
    ++a.checked;
  }
  return a;
}

// warmed up for 300 steps with more than `min_rows` contacts, `steps` more steps allocate nothing
void ExpectSteadyStepsAllocateNothing(World& w, size_t min_rows, int steps) {
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_GT(w.rows.size(), min_rows);
  const Allocations a = CountAllocations(w, steps);
  EXPECT_EQ(a.count, 0);
  EXPECT_GT(a.checked, 0) << "every step needed Newton: nothing was checked";
  EXPECT_GT(w.rows.size(), min_rows);
  EXPECT_EQ(w.rejected_steps, 0);
}

TEST(StepSafety, SteadyStateStepDoesNotAllocate) {
  World w;
  BuildScene(w);
  ExpectSteadyStepsAllocateNothing(w, 10, 200);
}

// steps whose pairs carry their last contacts (WorldParams::carry_contacts_after_s;
// here up to two of every three) allocate nothing either
TEST(StepSafety, StepsCarryingTheLastContactsDoNotAllocate) {
  World w;
  BuildScene(w);
  w.params.carry_contacts_after_s = 1e-12;  // every step that may carry does
  ExpectSteadyStepsAllocateNothing(w, 10, 200);
  EXPECT_GT(w.carried_steps, 100);
}

// the body pairs on a runner's lanes (World::UseRunner): listing, ordering and
// gathering them allocates nothing either
TEST(StepSafety, SteadyStateStepOnARunnersLanesDoesNotAllocate) {
  World w;
  BuildScene(w);
  test::ScriptedRunner runner(2, false);
  w.params.lanes_from_s = 0.0;
  w.UseRunner(&runner);
  ExpectSteadyStepsAllocateNothing(w, 10, 200);
  EXPECT_GT(runner.runs, 300);  // the counted steps and most of the warm-up on the lanes
  EXPECT_GE(w.profile.work.pairs_on_lanes, 2);
}

// a whole hand's finger: three soft balls carried by its links, each pulled 2 cm
// down by its drive (a tracked phalanx's coupling), the distal one pressed on the plane
void BuildSegmentFinger(World& w) {
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-7;
  w.params.solver.max_iterations = 200;
  test::AddPlane(w);
  Finger f;
  f.model.link_lengths = {0.03, 0.025, 0.02};
  f.model.limits = {{{-0.3, 0.3}, {-0.5, 1.6}, {0.0, 1.2}, {0.0, 1.2}}};
  f.model.base = Pose::Translation(Vec3(0, 0, 0.06));
  f.q = Vec4(0.0, 0.6, 0.3, 0.3);
  f.motor_stiffness = 0.0;
  f.joint_damping = 1e-4;
  const FingerKinematics k = FingerForward(f.model, Pose{}, f.q);
  for (int l = 0; l < 3; ++l) {
    BodySpec ball = test::SoftBall();
    ball.name = "segment" + std::to_string(l);
    ball.shape.radius = 0.008;
    ball.motion = EMotion::Fingertip;
    f.segment_offset[l] = Pose::Translation(Vec3(0.5 * f.model.link_lengths[l], 0, 0));
    ball.pose = k.link[l] * f.segment_offset[l];
    f.segment_body[l] = AddBody(w, ball);
  }
  w.hand.fingers.push_back(f);
  w.Finalize();
  for (int l = 0; l < 3; ++l) {
    Drive& d = w.bodies[f.segment_body[l]].drive;
    d.enabled = true;
    d.stiffness = Vec3::Constant(800.0);
    d.damping = Vec3::Constant(8.0);
    d.angular_stiffness = Vec3::Constant(0.02);
    d.angular_damping = Vec3::Constant(2e-4);
    d.max_force = 20.0;
    d.target = Pose::Translation(Vec3(0, 0, -0.02)) * w.bodies[f.segment_body[l]].pose;
  }
}

TEST(StepSafety, SteadyStateStepOfASegmentDrivenFingerDoesNotAllocate) {
  World w;
  BuildSegmentFinger(w);
  ExpectSteadyStepsAllocateNothing(w, 0, 100);
  for (const Body& b : w.bodies) EXPECT_TRUE(b.pose.t.allFinite());
}

TEST(StepSafety, SteadyStateStepWithJointLimitsDoesNotAllocate) {
  World w;
  BuildScene(w, true);
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_EQ(w.limit_rows.size(), 2u);
  const Allocations a = CountAllocations(w, 100);
  EXPECT_EQ(a.count, 0);
  EXPECT_GT(a.checked, 0);
  // both limits hold their joints with the motors' pull
  EXPECT_GT(w.limit_rows[0].r, 0.0);
  EXPECT_GT(w.limit_rows[1].r, 0.0);
  EXPECT_EQ(w.rejected_steps, 0);
}

TEST(StepSafety, StepBudgetEndsTheSolveEarlyCountsItAndAllocatesNothing) {
  World w;
  BuildScene(w);
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_GT(w.rows.size(), 10u);
  w.params.solver.tolerance = 1e-14;  // out of reach: without the budget every step sweeps to the cap
  w.params.step_time_budget_s = 1e-9;  // spent before the solve starts
  w.params.budget_may_skip_solve = true;
  g_allocations = 0;
  g_counting = true;
  // no time for a sweep: a step keeps the warm start (in the cones), but never two
  // in a row and never with more than 5 % new contacts; every other step sweeps once
  bool last_skipped = false;
  int skips = 0;
  for (int i = 0; i < 50; ++i) {
    w.Step();
    const bool skipped = w.profile.solve_skipped;
    const int n = static_cast<int>(w.rows.size());
    if (skipped) {
      ASSERT_FALSE(last_skipped) << i;
      ASSERT_LE(20 * (n - w.profile.work.warm_started), n) << i;
    } else if (!last_skipped) {
      ASSERT_GT(20 * (n - w.profile.work.warm_started), n) << i;  // it could have skipped otherwise
    }
    skips += skipped ? 1 : 0;
    last_skipped = skipped;
    ASSERT_EQ(w.profile.iterations, skipped ? 0 : 1) << i;
    ASSERT_TRUE(w.profile.budget_stopped) << i;
    ASSERT_FALSE(w.profile.converged) << i;
    ASSERT_TRUE(std::isfinite(w.profile.residual)) << i;
    for (const ContactRow& row : w.rows) {
      ASSERT_TRUE(row.r.allFinite()) << i;
      // in the cone |r_t| <= mu r_n
      ASSERT_LE(std::hypot(row.r[1], row.r[2]), row.mu * row.r[0] * (1 + 1e-12) + 1e-300) << i;
    }
  }
  g_counting = false;
  EXPECT_EQ(g_allocations.load(), 0);
  EXPECT_EQ(w.budget_stopped_steps, 50);
  EXPECT_EQ(w.skipped_solves, skips);
  EXPECT_GE(skips, 10);
  // with skips off, every step out of time sweeps once and reports its last
  // sweep's estimate (no exact pass)
  w.params.budget_may_skip_solve = false;
  for (int i = 0; i < 5; ++i) {
    w.Step();
    ASSERT_TRUE(w.profile.budget_stopped) << i;
    ASSERT_FALSE(w.profile.solve_skipped) << i;
    ASSERT_EQ(w.profile.iterations, 1) << i;
    EXPECT_TRUE(w.profile.residual_estimated) << i;
    EXPECT_FALSE(w.profile.residual_bounded) << i;
    if (i == 0) continue;  // its warm start may come from a step that kept the one before
    FcProblem p;
    Eigen::VectorXd r;
    AssembleContactProblem(w, &p, &r);
    const double exact = FcScaledError(p, r, StepGapScale(w.params));
    // the estimate is the error of the mixed iterate the sweep read, not of its
    // result: near the exact error, not a bound (1.5-2.2x it in a run of one-sweep
    // steps; here, a few steps after the skips, 4.3, 7.4, 50 and 4.6x: the 50 where
    // the exact error fell fourfold in that one sweep, the ball's normal forces
    // turning it about where it touches the table)
    EXPECT_GT(exact, w.params.solver.tolerance) << i;
    EXPECT_GT(w.profile.residual, 0.1 * exact) << i;
    EXPECT_LT(w.profile.residual, 100.0 * exact) << i;
  }
  EXPECT_EQ(w.budget_stopped_steps, 55);
  EXPECT_EQ(w.skipped_solves, skips);
  EXPECT_GE(w.unconverged_steps, 55);
  EXPECT_EQ(w.rejected_steps, 0);
  // budget off: the solve sweeps on (to the tolerance or the cap)
  w.params.step_time_budget_s = 0.0;
  w.Step();
  EXPECT_FALSE(w.profile.budget_stopped);
  EXPECT_FALSE(w.profile.solve_skipped);
  EXPECT_GT(w.profile.iterations, 10);
  EXPECT_EQ(w.budget_stopped_steps, 55);
  EXPECT_EQ(w.skipped_solves, skips);
}

// A step that skips its solve keeps the warm start: the last step's forces, each
// projected on its cone; the step after sweeps again from them.
TEST(StepSafety, SkippedSolveKeepsTheLastForces) {
  World w;
  BuildScene(w);
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_GT(w.rows.size(), 10u);
  std::vector<std::pair<uint64_t, Vec3>> last;  // world force of each contact key, sorted by key
  for (const ContactRow& row : w.rows) last.emplace_back(row.contact.key, row.frame.transpose() * row.r);
  std::sort(last.begin(), last.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  w.params.step_time_budget_s = 1e-9;
  w.params.budget_may_skip_solve = true;
  w.Step();
  ASSERT_TRUE(w.profile.solve_skipped);
  int compared = 0;
  for (const ContactRow& row : w.rows) {
    const auto it = std::lower_bound(last.begin(), last.end(), row.contact.key,
                                     [](const auto& x, uint64_t k) { return x.first < k; });
    const bool found = it != last.end() && it->first == row.contact.key;
    const Vec3 warm = found ? Vec3(row.frame * it->second) : Vec3::Zero();
    const Vec3 expect = ProjectOntoCone(warm, row.mu);
    EXPECT_LE((row.r - expect).norm(), 1e-12 * (1.0 + expect.norm())) << row.contact.key;
    compared += found ? 1 : 0;
  }
  EXPECT_GT(compared, 10);
  w.Step();
  EXPECT_FALSE(w.profile.solve_skipped);
  EXPECT_EQ(w.profile.iterations, 1);
  // contacts with no last force (here all of them: the last forces forgotten) are
  // solved, out of time or not
  w.Step();
  ASSERT_TRUE(w.profile.solve_skipped);
  w.Step();
  w.warm_prev.clear();
  w.Step();
  EXPECT_EQ(w.profile.work.warm_started, 0);
  EXPECT_FALSE(w.profile.solve_skipped);
  EXPECT_EQ(w.profile.iterations, 1);
}

// What the reported forces r move an articulation by: A^-1 H^T r summed over the
// contact sides on it (free bodies: J^T f = (f, lever x f + f_n spin)).
Vec6 ResponseOfReportedForces(const World& w, int articulation) {
  const Articulation& a = w.articulations[articulation];
  Vec6 dq = Vec6::Zero();
  for (const ContactRow& row : w.rows) {
    const Vec3 f = row.frame.transpose() * row.r;  // on side 0, world
    for (const ContactSide& s : row.side) {
      if (s.articulation != articulation) continue;
      dq.head<3>() += a.a_inv.topLeftCorner<3, 3>() * (s.sign * f);
      dq.tail<3>() += a.a_inv.bottomRightCorner<3, 3>() * (s.lever.cross(s.sign * f) + s.sign * row.r[0] * s.spin);
    }
  }
  return dq;
}

double TangentialShare(const World& w) {
  double t = 0.0, n = 0.0;
  for (const ContactRow& row : w.rows) {
    t += std::hypot(row.r[1], row.r[2]);
    n += row.r[0];
  }
  return t / n;
}

// A skipped solve keeps the warm start projected on the new cones; the bodies
// must move with those projected forces, not with the last step's (here outside
// the cones: friction dropped from 0.8 to 0.08 under a box held by friction).
TEST(StepSafety, SkippedSolveMovesTheBodiesWithTheForcesItReports) {
  World w;
  w.params.dt = 1e-3;
  w.params.sleep.enabled = false;
  w.params.default_friction = 0.8;
  test::AddPlane(w);
  BodySpec spec = test::SmallBox("box", Vec3(0, 0, 0.0102), 0.01);
  spec.drive.enabled = true;
  spec.drive.force = Vec3(0.2, 0, 0);  // 0.4 of the weight: friction holds it at mu 0.8
  const int box = AddBody(w, spec);
  w.Finalize();
  for (int i = 0; i < 300; ++i) w.Step();
  ASSERT_GT(w.rows.size(), 3u);
  ASSERT_GT(TangentialShare(w), 0.3);
  w.SetFriction(0, box, 0.08);
  w.params.step_time_budget_s = 1e-9;
  w.params.budget_may_skip_solve = true;
  const Pose before = w.bodies[box].pose;
  w.Step();
  ASSERT_TRUE(w.profile.solve_skipped);
  ASSERT_FALSE(w.profile.rejected);
  EXPECT_LE(TangentialShare(w), 0.08 * (1 + 1e-12));  // reported: projected on the cones
  const Articulation& a = w.articulations[w.bodies[box].articulation];
  const Vec6 expect = ResponseOfReportedForces(w, w.bodies[box].articulation);
  EXPECT_LE((a.dq - expect).norm(), 1e-9 * expect.norm());
  // and the box moved by its free motion plus that response
  const Vec3 moved = w.bodies[box].pose.t - before.t;
  EXPECT_LE((moved - (a.dq_free.head<3>() + expect.head<3>())).norm(), 1e-9 * moved.norm() + 1e-15);
}

TEST(StepSafety, NonFiniteStepIsRejectedAndThePreviousStateKept) {
  World w;
  BuildScene(w);
  for (int i = 0; i < 100; ++i) w.Step();
  const Pose before = w.bodies[1].pose;
  const std::vector<Vec3> u_before = w.bodies[1].u;
  // a NaN force on the ball: its free motion becomes NaN
  w.bodies[1].drive.force = Vec3(NAN, 0, 0);
  w.Step();
  EXPECT_TRUE(w.profile.rejected);
  EXPECT_EQ(w.rejected_steps, 1);
  EXPECT_EQ((w.bodies[1].pose.t - before.t).norm(), 0.0);
  EXPECT_EQ((w.bodies[1].pose.R - before.R).norm(), 0.0);
  for (size_t j = 0; j < u_before.size(); ++j) ASSERT_EQ((w.bodies[1].u[j] - u_before[j]).norm(), 0.0);
  for (const Body& b : w.bodies) {
    EXPECT_TRUE(b.pose.t.allFinite());
    EXPECT_TRUE(b.pose.R.allFinite());
  }
  // the simulation goes on once the input is finite again
  w.bodies[1].drive.force = Vec3(0.05, 0, 0);
  for (int i = 0; i < 50; ++i) w.Step();
  EXPECT_EQ(w.rejected_steps, 1);
  EXPECT_TRUE(w.bodies[1].pose.t.allFinite());
  EXPECT_GT(w.rows.size(), 3u);
}

}  // namespace
}  // namespace gs

namespace gs {
namespace {

// At rest the step's solve converges in its first sweep on a bound of the error
// (no exact pass); the bound holds the exact error of the step's problem.
TEST(StepSafety, StepsAtRestReportABoundThatHoldsTheExactError) {
  // a soft 6 cm box resting on the plane (awake: sleep off)
  World w;
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-7;
  w.params.solver.max_iterations = 200;
  w.params.sleep.enabled = false;
  test::AddPlane(w);
  BodySpec box = test::SmallBox("box", Vec3(0, 0, 0.0301), 0.03);
  box.deformation.model = EDeformation::Gaussian;
  box.deformation.stiffness = 20000;
  box.deformation.damping = 20;
  box.deformation.influence_radius = 0.003;
  ASSERT_GE(AddBody(w, box), 0);
  w.Finalize();
  for (int i = 0; i < 600; ++i) w.Step();
  int bounded = 0, checked = 0;
  for (int i = 0; i < 100; ++i) {
    w.Step();
    ASSERT_TRUE(w.profile.converged) << i;
    if (!w.profile.residual_bounded) continue;
    ++bounded;
    EXPECT_LE(w.profile.residual, w.params.solver.tolerance);
    if (i % 10 == 0) {
      FcProblem p;
      Eigen::VectorXd r;
      AssembleContactProblem(w, &p, &r);
      // both measures: the scaled one the step stops on, and Siconos'
      EXPECT_LE(FcScaledError(p, r, StepGapScale(w.params)), w.profile.residual * (1.0 + 1e-9) + 1e-300) << i;
      EXPECT_LE(FcError(p, r), w.profile.residual_siconos * (1.0 + 1e-9) + 1e-300) << i;
      ++checked;
    }
  }
  EXPECT_GT(bounded, 50);
  EXPECT_GT(checked, 3);
}

}  // namespace
}  // namespace gs

namespace gs {
namespace {

bool IsSubnormal(double x) { return std::fpclassify(x) == FP_SUBNORMAL; }

// the guard flushes subnormal operands and results inside its scope only
TEST(FloatMode, GuardFlushesSubnormalsInItsScopeOnly) {
  // without SSE's MXCSR (not x86) the guard does nothing and there is nothing to check
  if (!FlushSubnormals::kSupported) GTEST_SKIP() << "no MXCSR on this platform: subnormals are not flushed";
  volatile double tiny = 1e-310;  // subnormal (smallest normal: 2.2e-308)
  volatile double half = 0.5;
  ASSERT_TRUE(IsSubnormal(tiny));
  const double before = tiny * half;
  EXPECT_TRUE(IsSubnormal(before));
  {
    const FlushSubnormals flush;
    const double inside = tiny * half;         // subnormal operand: read as zero
    EXPECT_EQ(inside, 0.0);
    volatile double small = 1e-300;
    const double underflow = small * 1e-10;    // would-be subnormal result: zero
    EXPECT_EQ(underflow, 0.0);
  }
  EXPECT_EQ(tiny * half, before);  // the caller's mode is back
}

// A deformable body whose displacements decay into the subnormal range (a body
// coming to rest under damping) leaves the step with them at zero, and the
// caller's floating-point mode is untouched: the step's arithmetic never runs
// on subnormals, which cost some hundred cycles per operation.
TEST(StepSafety, DecayedDisplacementsLeaveTheStepAtZero) {
  // without SSE's MXCSR (not x86) the step keeps subnormals: nothing to check
  if (!FlushSubnormals::kSupported) GTEST_SKIP() << "no MXCSR on this platform: subnormals are not flushed";
  World w;
  w.params.dt = 1e-3;
  w.params.gravity = Vec3::Zero();
  const int ball = AddBody(w, test::SoftBall(Vec3(0, 0, 0.5)));
  ASSERT_GE(ball, 0);
  w.Finalize();
  w.Step();
  Body& b = w.bodies[ball];
  ASSERT_FALSE(b.u.empty());
  for (Vec3& u : b.u) u = Vec3(1e-310, -3e-310, 2e-309);  // subnormal displacements
  w.WakeAll();
  w.Step();
  int subnormal = 0, nonzero = 0;
  for (const Vec3& u : b.u)
    for (int i = 0; i < 3; ++i) {
      subnormal += IsSubnormal(u[i]) ? 1 : 0;
      nonzero += u[i] != 0.0 ? 1 : 0;
    }
  EXPECT_EQ(subnormal, 0);
  EXPECT_EQ(nonzero, 0);
  volatile double tiny = 1e-310;
  EXPECT_TRUE(IsSubnormal(tiny * 0.5));  // the step restored the caller's mode
}

}  // namespace
}  // namespace gs
