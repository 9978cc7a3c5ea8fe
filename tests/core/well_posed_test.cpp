// Ill-posed worlds are refused before their first step (WellPosedError), and a
// step that meets a non-finite value anywhere (an input bypassing the scene
// loader, a poisoned contact) is rejected with the previous state kept.
#include "core/well_posed.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

namespace gs {
namespace {

bool Mentions(const std::string& text, const std::string& word) { return text.find(word) != std::string::npos; }

BodySpec Box(const char* name, double mass) {
  BodySpec b;
  b.name = name;
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3::Constant(0.01);
  b.geometry.points = 800;
  b.geometry.control_points = 80;
  b.mass = mass;
  b.pose = Pose::Translation(Vec3(0, 0, 0.0101));
  return b;
}

// a plane, a deformable box resting on it (pushed by a drive) and one finger above
void BuildWorld(World& w, const BodySpec& box) {
  w.params.dt = 1e-3;
  w.params.solver.tolerance = 1e-7;
  BodySpec plane;
  plane.name = "plane";
  plane.is_plane = true;
  AddBody(w, plane);
  AddBody(w, box);
  BodySpec tip;
  tip.name = "tip";
  tip.shape.type = EShape::Sphere;
  tip.shape.radius = 0.006;
  tip.geometry.points = 400;
  tip.geometry.control_points = 40;
  tip.motion = EMotion::Fingertip;
  const int t = AddBody(w, tip);
  Finger f;
  f.name = "f";
  f.model.base = Pose::Translation(Vec3(-0.05, 0, 0.08));
  f.model.link_lengths = {0.03, 0.02, 0.015};
  f.model.limits = {{{-0.6, 0.6}, {-0.2, 1.6}, {0.0, 1.8}, {0.0, 1.6}}};
  f.body = t;
  f.motor_stiffness = 2.0;
  f.motor_damping = 0.02;
  w.hand.fingers.push_back(f);
  w.Finalize();
}

BodySpec RestingBox() {
  BodySpec b = Box("box", 0.05);
  b.deformation.model = EDeformation::Gaussian;
  b.deformation.stiffness = 2000;
  b.deformation.damping = 1;
  b.deformation.influence_radius = 0.003;
  b.drive.enabled = true;
  b.drive.force = Vec3(0.02, 0, 0);
  return b;
}

TEST(WellPosed, ShippedKindOfWorldIsAccepted) {
  World w;
  BuildWorld(w, RestingBox());
  EXPECT_EQ(WellPosedError(w), "");
}

// The bug this check exists for: a free inertial body of zero mass solves
// 0 * dq = m g in its free motion. Before the check it was accepted and every one of
// its steps came out NaN and was rejected, forever, without a word.
TEST(WellPosed, ZeroMassFreeBodyIsRefusedAndItsStepsNeverLeaveNaN) {
  World w;
  BuildWorld(w, Box("massless", 0.0));
  const std::string why = WellPosedError(w);
  EXPECT_TRUE(Mentions(why, "massless")) << why;
  EXPECT_TRUE(Mentions(why, "mass")) << why;
  // stepped anyway, free motion is NaN: each step is rejected, nothing non-finite stays
  const Pose start = w.bodies[1].pose;
  for (int i = 0; i < 3; ++i) {
    w.Step();
    EXPECT_TRUE(w.profile.rejected);
    EXPECT_TRUE(Mentions(w.profile.reject_reason, "free motion")) << w.profile.reject_reason;
  }
  EXPECT_EQ(w.rejected_steps, 3);
  EXPECT_EQ((w.bodies[1].pose.t - start.t).norm(), 0.0);
  for (const Body& b : w.bodies) {
    EXPECT_TRUE(b.pose.t.allFinite() && b.pose.R.allFinite()) << b.name;
    EXPECT_TRUE(b.velocity.allFinite()) << b.name;
  }
}

// one ill-posed parameter at a time, each named in the message
TEST(WellPosed, EveryIllPosedParameterIsNamed) {
  struct Case {
    const char* what;
    std::function<void(BodySpec&)> body;
    std::function<void(World&)> world;
    const char* expect;
  };
  const Case cases[] = {
      {"negative mass", [](BodySpec& b) { b.mass = -1; }, nullptr, "mass"},
      {"NaN mass", [](BodySpec& b) { b.mass = NAN; }, nullptr, "mass"},
      {"inertia not positive definite", [](BodySpec& b) { b.inertia = Vec3(1e-5, 1e-5, -1e-6).asDiagonal(); },
       nullptr, "positive definite"},
      {"inertia not symmetric", [](BodySpec& b) {
         b.inertia = Vec3(1e-5, 1e-5, 1e-5).asDiagonal();
         b.inertia(0, 1) = 5e-6;
       }, nullptr, "positive definite"},
      {"quasi-static without damping", [](BodySpec& b) {
         b.dynamics = EDynamics::QuasiStatic;
         b.drive.enabled = false;
       }, nullptr, "quasi-static body needs linear damping"},
      {"quasi-static, drive on two axes only", [](BodySpec& b) {
         b.dynamics = EDynamics::QuasiStatic;
         b.linear_damping = 0;
         b.angular_damping = 1;
         b.drive.stiffness = Vec3(10, 10, 0);
       }, nullptr, "translation"},
      {"negative damping", [](BodySpec& b) { b.linear_damping = -0.1; }, nullptr, "damping"},
      {"NaN drive target", [](BodySpec& b) { b.drive.target.t.x() = NAN; }, nullptr, "drive target"},
      {"negative drive gain", [](BodySpec& b) { b.drive.stiffness = Vec3(-1, 0, 0); }, nullptr, "drive gains"},
      {"infinite velocity", [](BodySpec& b) { b.velocity.z() = INFINITY; }, nullptr, "velocity"},
      {"negative stiffness", [](BodySpec& b) { b.deformation.stiffness = -5; }, nullptr, "stiffness"},
      {"negative deformation damping", [](BodySpec& b) { b.deformation.damping = -1; }, nullptr, "damping"},
      {"zero influence radius", [](BodySpec& b) { b.deformation.influence_radius = 0; }, nullptr, "influence"},
      {"Poisson ratio 0.5", [](BodySpec& b) {
         b.deformation.model = EDeformation::Boussinesq;
         b.deformation.young_modulus = 1e5;
         b.deformation.poisson_ratio = 0.5;
       }, nullptr, "Poisson"},
      {"zero Young's modulus", [](BodySpec& b) {
         b.deformation.model = EDeformation::Boussinesq;
         b.deformation.young_modulus = 0;
       }, nullptr, "Young"},
      {"dt = 0", nullptr, [](World& w) { w.params.dt = 0; }, "time step"},
      {"dt < 0", nullptr, [](World& w) { w.params.dt = -1e-3; }, "time step"},
      {"NaN dt", nullptr, [](World& w) { w.params.dt = NAN; }, "time step"},
      {"mu < 0 (default)", nullptr, [](World& w) { w.params.default_friction = -0.1; }, "friction"},
      {"mu < 0 (pair)", nullptr, [](World& w) { w.SetFriction(1, 2, -0.5); }, "friction"},
      {"mu = Inf (pair)", nullptr, [](World& w) { w.SetFriction(0, 1, INFINITY); }, "friction"},
      {"NaN gravity", nullptr, [](World& w) { w.params.gravity.y() = NAN; }, "gravity"},
      {"zero tolerance", nullptr, [](World& w) { w.params.solver.tolerance = 0; }, "tolerance"},
      {"over-relaxation 2", nullptr, [](World& w) { w.params.solver.over_relaxation = 2; }, "over-relaxation"},
      {"zero sweeps", nullptr, [](World& w) { w.params.solver.max_iterations = 0; }, "sweep"},
      {"negative contact threshold", nullptr, [](World& w) { w.params.collision.contact_threshold = -1e-4; },
       "threshold"},
      {"NaN joint-limit margin", nullptr, [](World& w) { w.params.joint_limit_margin = NAN; }, "joint-limit margin"},
      {"NaN hand pose", nullptr, [](World& w) { w.hand.pose.t.z() = NAN; }, "hand"},
      {"zero motor stiffness", nullptr, [](World& w) { w.hand.fingers[0].motor_stiffness = 0; }, "motor stiffness"},
      {"negative joint damping", nullptr, [](World& w) { w.hand.fingers[0].joint_damping = -1; }, "damping"},
      {"zero link", nullptr, [](World& w) { w.hand.fingers[0].model.link_lengths[1] = 0; }, "link"},
      {"NaN joint target", nullptr, [](World& w) { w.hand.fingers[0].q_target[2] = NAN; }, "joints"},
      {"inverted joint limit", nullptr, [](World& w) { w.hand.fingers[0].model.limits[1] = {{1.0, 0.0}}; }, "limit"},
  };
  for (const Case& c : cases) {
    BodySpec b = RestingBox();
    if (c.body) c.body(b);
    World w;
    BuildWorld(w, b);
    if (c.world) c.world(w);
    const std::string why = WellPosedError(w);
    EXPECT_TRUE(Mentions(why, c.expect)) << c.what << ": '" << why << "'";
  }
}

// The stages of World::Step, with a hook after each: values poisoned between stages
// bypass every loader and every earlier check.
void StepWithHook(World& w, const std::function<void(World&, int)>& hook) {
  w.profile = StepProfile{};
  hook(w, 0);
  FreeMotion(w);
  hook(w, 1);
  DetectCollisions(w);
  hook(w, 2);
  BuildContactSpace(w);
  hook(w, 3);
  SolveContacts(w);
  hook(w, 4);
  ConstrainedMotion(w);
  w.time += w.params.dt;
  ++w.step_count;
  if (w.profile.rejected) ++w.rejected_steps;
}

struct Snapshot {
  std::vector<Pose> poses;
  std::vector<std::vector<Vec3>> u;
  std::vector<Vec4> q;
  explicit Snapshot(const World& w) {
    for (const Body& b : w.bodies) {
      poses.push_back(b.pose);
      u.push_back(b.u);
    }
    for (const Finger& f : w.hand.fingers) q.push_back(f.q);
  }
  // bit-identical state
  void ExpectSame(const World& w, const char* what) const {
    for (size_t i = 0; i < poses.size(); ++i) {
      EXPECT_EQ((w.bodies[i].pose.t - poses[i].t).norm(), 0.0) << what << ": " << w.bodies[i].name;
      EXPECT_EQ((w.bodies[i].pose.R - poses[i].R).norm(), 0.0) << what << ": " << w.bodies[i].name;
      for (size_t j = 0; j < u[i].size(); ++j) ASSERT_EQ((w.bodies[i].u[j] - u[i][j]).norm(), 0.0) << what;
    }
    for (size_t f = 0; f < q.size(); ++f) EXPECT_EQ((w.hand.fingers[f].q - q[f]).norm(), 0.0) << what;
  }
};

void ExpectAllFinite(const World& w, const char* what) {
  for (const Body& b : w.bodies) {
    EXPECT_TRUE(b.pose.t.allFinite() && b.pose.R.allFinite() && b.velocity.allFinite() &&
                b.angular_velocity.allFinite())
        << what << ": " << b.name;
    for (const Vec3& u : b.u) ASSERT_TRUE(u.allFinite()) << what << ": " << b.name;
  }
  for (const Finger& f : w.hand.fingers) EXPECT_TRUE(f.q.allFinite()) << what;
  for (const ContactRow& r : w.rows) ASSERT_TRUE(r.r.allFinite()) << what;
  EXPECT_TRUE(w.hand.pose.t.allFinite()) << what;
}

TEST(WellPosed, NonFiniteValueInjectedIntoAnyStageRejectsTheStep) {
  struct Case {
    const char* what;
    int stage;  // the hook's stage index
    std::function<void(World&)> poison;
    const char* reason;
  };
  const Case cases[] = {
      {"tracker target NaN (drive target set directly)", 0,
       [](World& w) { w.bodies[1].drive.target.t.x() = NAN; }, "free motion"},
      {"drive force Inf", 0, [](World& w) { w.bodies[1].drive.force.z() = INFINITY; }, "free motion"},
      {"finger joint target NaN", 0, [](World& w) { w.hand.fingers[0].q_target[1] = NAN; }, "free motion"},
      {"hand pose NaN", 0, [](World& w) { w.hand.pose.t.x() = NAN; }, "hand pose"},
      {"contact gap NaN", 2, [](World& w) { w.contacts.items[0].gap = NAN; }, "contact space"},
      {"contact normal NaN", 2, [](World& w) { w.contacts.items[0].normal.y() = NAN; }, "contact space"},
      {"contact anchor Inf", 2, [](World& w) { w.contacts.items[0].anchor[1].x() = INFINITY; }, "contact space"},
      {"Delassus block NaN", 3, [](World& w) { w.rows[0].w_diag(1, 1) = NAN; }, "contact space"},
      {"free slip Inf", 3, [](World& w) { w.rows[0].q[2] = INFINITY; }, "contact space"},
      {"friction coefficient NaN", 3, [](World& w) { w.rows[0].mu = NAN; }, "contact space"},
      {"contact force NaN after the solve", 4, [](World& w) { w.rows[0].r[0] = NAN; }, "solve"},
      {"body response NaN after the solve", 4, [](World& w) { w.articulations[0].dq[3] = NAN; }, "solve"},
      {"displacement NaN after the solve", 4, [](World& w) { w.bodies[1].u_acc[3].x() = NAN; }, "solve"},
      {"displacement -Inf after the solve", 4, [](World& w) { w.bodies[1].u_acc[7].z() = -INFINITY; }, "solve"},
      {"relaxed displacement Inf", 1, [](World& w) { w.bodies[1].u_free[5].y() = INFINITY; }, "free motion"},
  };
  for (const Case& c : cases) {
    World w;
    BuildWorld(w, RestingBox());
    for (int i = 0; i < 40; ++i) w.Step();
    ASSERT_GT(w.contacts.items.size(), 3u);
    ASSERT_EQ(w.rejected_steps, 0);
    const Snapshot before(w);
    StepWithHook(w, [&](World& ww, int stage) {
      if (stage == c.stage) c.poison(ww);
    });
    EXPECT_TRUE(w.profile.rejected) << c.what;
    EXPECT_EQ(w.rejected_steps, 1) << c.what;
    EXPECT_TRUE(Mentions(w.profile.reject_reason, c.reason)) << c.what << ": " << w.profile.reject_reason;
    before.ExpectSame(w, c.what);
    ExpectAllFinite(w, c.what);
    // the next clean steps go on from the kept state (inputs restored where they persist)
    w.bodies[1].drive.target = w.bodies[1].pose;
    w.bodies[1].drive.force = Vec3(0.02, 0, 0);
    w.hand.fingers[0].q_target = w.hand.fingers[0].q;
    if (!w.hand.pose.t.allFinite()) w.hand.pose = w.hand.pose_prev;
    for (int i = 0; i < 5; ++i) w.Step();
    EXPECT_EQ(w.rejected_steps, 1) << c.what;
    ExpectAllFinite(w, c.what);
  }
}

}  // namespace
}  // namespace gs
