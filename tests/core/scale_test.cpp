// The step's stopping measure is scale-invariant (core/nsgs.h, EStopMeasure::Scaled):
// multiplying every mass by k multiplies every force by k and changes nothing
// else, neither the trajectory nor the sweeps each step takes. Siconos' measure,
// which mixes forces and gaps, does not have that property (checked too, so that
// these tests tell the two apart).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/fc_problem.h"
#include "core/world.h"

namespace gs {
namespace {

// a heavy box (ratio x the bottom one) 5 mm off-centre on a light box on a table,
// mu 0.5, every mass x scale
struct Stack {
  World w;
  int bottom = -1, top = -1;
};

BodySpec Cube(const char* name, double mass, const Vec3& at) {
  BodySpec b;
  b.name = name;
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3::Constant(0.02);
  b.geometry.points = 1500;
  b.geometry.control_points = 200;
  b.mass = mass;
  b.pose = Pose::Translation(at);
  return b;
}

void BuildStack(Stack* s, double ratio, double scale, EStopMeasure measure) {
  World& w = s->w;
  w.params.dt = 1e-3;
  w.params.default_friction = 0.5;
  w.params.solver.measure = measure;
  BodySpec plane;
  plane.name = "table";
  plane.is_plane = true;
  AddBody(w, plane);
  s->bottom = AddBody(w, Cube("bottom", 0.1 * scale, Vec3(0, 0, 0.0203)));
  s->top = AddBody(w, Cube("top", 0.1 * ratio * scale, Vec3(0.005, 0, 0.0606)));
  w.Finalize();
}

struct Trace {
  std::vector<Vec3> x;    // both centres, step after step
  std::vector<int> sweeps;
  double force = 0.0;     // normal force sum of the last step
};

Trace Run(double ratio, double scale, EStopMeasure measure, int steps) {
  Stack s;
  BuildStack(&s, ratio, scale, measure);
  Trace t;
  for (int i = 0; i < steps; ++i) {
    s.w.Step();
    EXPECT_FALSE(s.w.profile.rejected) << i;
    t.x.push_back(s.w.bodies[s.bottom].pose.t);
    t.x.push_back(s.w.bodies[s.top].pose.t);
    t.sweeps.push_back(s.w.profile.iterations);
  }
  for (const ContactRow& r : s.w.rows) t.force += r.r[0];
  return t;
}

double MaxGap(const Trace& a, const Trace& b) {
  double g = 0.0;
  for (size_t i = 0; i < a.x.size(); ++i) g = std::max(g, (a.x[i] - b.x[i]).norm());
  return g;
}

int Mismatches(const Trace& a, const Trace& b) {
  int n = 0;
  for (size_t i = 0; i < a.sweeps.size(); ++i) n += a.sweeps[i] != b.sweeps[i] ? 1 : 0;
  return n;
}

int TotalSweeps(const Trace& t) {
  int n = 0;
  for (int s : t.sweeps) n += s;
  return n;
}

TEST(Scale, EveryMassTimesKGivesTheSameTrajectoryAndSweeps) {
  const int steps = 400;  // the landing and 0.35 s at rest
  const Trace base = Run(10.0, 1.0, EStopMeasure::Scaled, steps);
  for (const double k : {10.0, 1000.0}) {
    const Trace t = Run(10.0, k, EStopMeasure::Scaled, steps);
    EXPECT_NEAR(t.force, k * base.force, 1e-9 * k * base.force) << k;  // the forces did scale
    EXPECT_LT(MaxGap(base, t), 1e-12) << k;
    EXPECT_EQ(Mismatches(base, t), 0) << k;
  }
}

// The same scenes stopped on Siconos' measure: a different number of sweeps (the
// tolerance means something else at another mass scale).
TEST(Scale, SiconosMeasureIsNotScaleInvariant) {
  const int steps = 400;
  const Trace base = Run(10.0, 1.0, EStopMeasure::Siconos, steps);
  const Trace heavy = Run(10.0, 1000.0, EStopMeasure::Siconos, steps);
  EXPECT_GT(Mismatches(base, heavy), steps / 10);
  EXPECT_NE(TotalSweeps(base), TotalSweeps(heavy));
}

// The measure itself, on an explicit problem: W / k and k r give the same scaled
// error, and Siconos' error changes.
TEST(Scale, ScaledMeasureIsInvariantUnderForceScaling) {
  const FcProblem p = RandomRigidProblem(52, 4, 3);
  FcSolveParams sp;
  sp.nsgs.max_iterations = 30;  // far from converged: a sizeable error
  Eigen::VectorXd r;
  SolveFcProblem(p, sp, &r);
  const double gap = 9.81e-6;
  const double e1 = FcScaledError(p, r, gap);
  ASSERT_GT(e1, 1e-6);
  for (const double k : {10.0, 1000.0}) {
    FcProblem pk = p;
    pk.W = p.W / k;
    const Eigen::VectorXd rk = k * r;
    EXPECT_NEAR(FcScaledError(pk, rk, gap), e1, 1e-12 * e1) << k;
    EXPECT_GT(std::abs(FcError(pk, rk) - FcError(p, r)), 0.05 * FcError(p, r)) << k;
  }
}

}  // namespace
}  // namespace gs
