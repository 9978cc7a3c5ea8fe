#include "scene/scene_file.h"

#include "core/body_geometry.h"
#include "scene/scene_checks.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

namespace gs::app {
namespace {

const char* kMinimal = R"(scene: t
timestep_s: 0.001
duration_s: 1.0
bodies:
  - name: table
    shape: {type: plane}
    motion: fixed
  - name: ball
    shape: {type: sphere, radius_m: 0.01}
    points: 500
    control_points: 60
    position_m: [0, 0, 0.0102]
    mass_kg: 0.05
)";

std::vector<SceneError> Errors(const std::string& text) {
  Scene s;
  std::vector<SceneError> errors;
  EXPECT_FALSE(LoadSceneFromString(text, "t.yaml", &s, &errors)) << text;
  return errors;
}

// the first error's position and whether its message mentions `word`
void ExpectError(const std::string& text, int line, int column, const std::string& word) {
  const std::vector<SceneError> e = Errors(text);
  ASSERT_FALSE(e.empty());
  EXPECT_EQ(e[0].file, "t.yaml");
  EXPECT_EQ(e[0].line, line) << e[0].Format();
  EXPECT_EQ(e[0].column, column) << e[0].Format();
  EXPECT_NE(e[0].message.find(word), std::string::npos) << e[0].Format();
}

TEST(SceneFile, EveryShippedSceneLoads) {
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(GRASPSIM_SOURCE_DIR) + "/config")) {
    if (entry.path().extension() != ".yaml") continue;
    Scene s;
    std::vector<SceneError> errors;
    EXPECT_TRUE(LoadScene(entry.path().string(), &s, &errors)) << entry.path() << ": "
                                                                << (errors.empty() ? "" : errors[0].Format());
    ++n;
  }
  EXPECT_GE(n, 1);
}

TEST(SceneFile, MinimalSceneLoadsAndBuilds) {
  Scene s;
  std::vector<SceneError> errors;
  ASSERT_TRUE(LoadSceneFromString(kMinimal, "t.yaml", &s, &errors));
  ASSERT_EQ(s.bodies.size(), 2u);
  EXPECT_TRUE(s.bodies[0].spec.is_plane);
  EXPECT_DOUBLE_EQ(s.bodies[1].spec.mass, 0.05);
  EXPECT_DOUBLE_EQ(s.bodies[1].spec.pose.t.z(), 0.0102);
  BuiltScene built;
  std::string error;
  ASSERT_TRUE(BuildScene(s, &built, &error)) << error;
  EXPECT_EQ(built.world.bodies[1].geometry.tree.num_leaves(), 60);
  EXPECT_EQ(built.tracked_body, 1);
}

TEST(SceneFile, UnknownKeysAreRefusedWithTheirPosition) {
  std::string t = kMinimal;
  t += "gravty_m_s2: [0, 0, -9.81]\n";
  ExpectError(t, 14, 1, "unknown key 'gravty_m_s2'");
  std::string nested = kMinimal;
  nested.replace(nested.find("    mass_kg"), 0, "    masss_kg: 1\n");
  ExpectError(nested, 13, 5, "unknown key 'masss_kg'");
}

TEST(SceneFile, WrongTypesRangesAndIllPosedValues) {
  std::string t = kMinimal;
  ExpectError(std::string(kMinimal).replace(std::string(kMinimal).find("0.001"), 5, "fast"), 2, 13, "finite number");
  ExpectError(std::string(kMinimal).replace(std::string(kMinimal).find("0.001"), 5, "0"), 2, 13, "out of range");
  ExpectError(std::string(kMinimal).replace(std::string(kMinimal).find("0.001"), 5, "-0.1"), 2, 13, "out of range");
  ExpectError(std::string(kMinimal).replace(std::string(kMinimal).find("0.05"), 4, ".nan"), 13, 14, "finite");
  ExpectError(std::string(kMinimal).replace(std::string(kMinimal).find("points: 500"), 11, "points: many"), 10, 13,
              "whole number");
  std::string mu = kMinimal;
  mu += "friction: {default: -0.1}\n";
  ExpectError(mu, 14, 21, "out of range");
  std::string k = kMinimal;
  k += "    deformation: {model: gaussian, stiffness_N_m: -5, influence_radius_m: 0.002}\n";
  ExpectError(k, 14, 51, "out of range");
  std::string cps = std::string(kMinimal).replace(std::string(kMinimal).find("control_points: 60"), 18,
                                                  "control_points: 600");
  ExpectError(cps, 11, 21, "cannot exceed");
}

// kMinimal with `extra` appended to the ball's mapping
std::string WithBall(const std::string& extra) { return std::string(kMinimal) + extra; }

// kMinimal with a fixed Boussinesq pad under the ball: `pad_cps` control points, one-pass
// (`pad_emits` false) or two-pass, and the ball's control points `ball_cps`
std::string WithPad(int pad_cps, bool pad_emits, int ball_cps) {
  std::string t = std::string(kMinimal).replace(std::string(kMinimal).find("points: 500"), 11, "points: 1600");
  t.replace(t.find("control_points: 60"), 18, "control_points: " + std::to_string(ball_cps));
  return t + "  - name: pad\n    shape: {type: box, size_m: [0.04, 0.04, 0.01]}\n    motion: fixed\n"
             "    position_m: [0, 0, -0.03]\n    points: 4000\n    control_points: " +
         std::to_string(pad_cps) + "\n    contact_points: " + (pad_emits ? "true" : "false") +
         "\n    deformation: {model: boussinesq, young_modulus_Pa: 1e5, poisson_ratio: 0.45}\n";
}

// one-pass contact on a Boussinesq surface by a body with sparser control points: the
// surface bulges between them (a rigid sphere 18 % too deep at twice the spacing)
TEST(SceneFile, OnePassOnABoussinesqSurfaceNeedsPointsAsDenseAsItsOwn) {
  Scene s;
  std::vector<SceneError> errors;
  BuiltScene built;
  std::string error;
  // the ball's 60 control points are 4.6 mm apart, the pad's 1,000 2.2 mm: refused at the ball
  const std::string coarse = WithPad(1000, false, 60);
  ASSERT_TRUE(LoadSceneFromString(coarse, "t.yaml", &s, &errors));
  EXPECT_FALSE(BuildScene(s, &built, &error));
  EXPECT_NE(error.find("t.yaml:8:5"), std::string::npos) << error;
  EXPECT_NE(error.find("Boussinesq surface of 'pad'"), std::string::npos) << error;
  EXPECT_NE(error.find("Give 'ball' control_points >= "), std::string::npos) << error;
  // what it suggests builds, and so do two-pass contact and a coarse pad
  const size_t at = error.find(">= ") + 3;
  const int suggested = std::stoi(error.substr(at));
  EXPECT_GT(suggested, 60);
  for (const std::string& ok : {WithPad(1000, false, suggested), WithPad(1000, true, 60), WithPad(150, false, 60)}) {
    Scene fine;
    BuiltScene fine_built;
    ASSERT_TRUE(LoadSceneFromString(ok, "t.yaml", &fine, &errors)) << (errors.empty() ? "" : errors[0].Format());
    EXPECT_TRUE(BuildScene(fine, &fine_built, &error)) << error;
  }
}

// kMinimal's ball (radius 10 mm) resting on a fixed 6 cm pad with `pad_cps` control
// points, one-pass on the ball (`ball_emits` false: only the pad's points touch it)
std::string BallOnPad(int pad_cps, bool ball_emits) {
  std::string t = kMinimal;
  t.replace(t.find("    mass_kg: 0.05\n"), 0, std::string("    contact_points: ") + (ball_emits ? "true" : "false") + "\n");
  return t + "  - name: pad\n    shape: {type: box, size_m: [0.06, 0.06, 0.01]}\n    motion: fixed\n"
             "    position_m: [0, 0, -0.005]\n    points: 6000\n    control_points: " +
         std::to_string(pad_cps) + "\n";
}

// A rigid sphere resting on a sampled face's control points sinks between them no
// deeper than SinkBetweenControlPoints says, and not much less: its widest gap,
// kGapPerSpacing of the spacing, is measured here on the top face of a 6 cm box.
TEST(SceneFile, ASphereRestingOnControlPointsSinksAsTheCheckPredicts) {
  for (int cps : {400, 1200, 4800}) {
    ShapeDesc box;
    box.type = EShape::Box;
    box.half_extents = Vec3::Constant(0.03);
    GeometryOptions o;
    o.points = 15 * cps / 2;
    o.control_points = cps;
    BodyGeometry g;
    ASSERT_EQ(BuildShapeGeometry(box, o, &g), EGeometryError::None);
    const double spacing = std::sqrt(g.area / cps);
    std::vector<Vec3> top;
    for (const Vec3& c : g.tree.control_points())
      if (c.z() > 0.03 - 1e-9) top.push_back(c);
    for (double r : {0.007, 0.0095}) {
      // the sphere lowered onto the face over a 0.25 mm grid of its interior: its lowest
      // point comes to rest below the face by `sink`
      double deepest = 0.0;
      for (double x = -0.03 + r; x <= 0.03 - r; x += 2.5e-4)
        for (double y = -0.03 + r; y <= 0.03 - r; y += 2.5e-4) {
          double centre = -1.0;
          for (const Vec3& c : top) {
            const double d2 = (c.x() - x) * (c.x() - x) + (c.y() - y) * (c.y() - y);
            if (d2 < r * r) centre = std::max(centre, c.z() + std::sqrt(r * r - d2));
          }
          deepest = std::max(deepest, centre < 0.0 ? r : 0.03 - (centre - r));
        }
      const double predicted = SinkBetweenControlPoints(r, spacing);
      EXPECT_LE(deepest, predicted * (1.0 + 1e-9)) << cps << " control points, radius " << r;
      // and the widest gap is at least 0.85 of the spacing: the bound is not loose
      const double gap = std::sqrt(r * r - (r - deepest) * (r - deepest));
      EXPECT_GE(gap, 0.85 * spacing) << cps << " control points, radius " << r;
    }
  }
}

// one-pass contact on a curved surface by a body whose control points are too far apart:
// the ball resting on them would sink between them deeper than its smallest leaf
TEST(SceneFile, OnePassOnACurvedSurfaceNeedsPointsCloserThanItsCurvature) {
  Scene s;
  std::vector<SceneError> errors;
  BuiltScene built;
  std::string error;
  // the pad's 60 control points are 13 mm apart: the 10 mm ball would fall to its centre
  ASSERT_TRUE(LoadSceneFromString(BallOnPad(60, false), "t.yaml", &s, &errors));
  EXPECT_FALSE(BuildScene(s, &built, &error));
  EXPECT_NE(error.find("t.yaml:15:5"), std::string::npos) << error;
  EXPECT_NE(error.find("body 'pad' touches 'ball' in one-pass contact"), std::string::npos) << error;
  EXPECT_NE(error.find("'ball' sinks up to 10 mm"), std::string::npos) << error;
  EXPECT_NE(error.find("relative curvature radius 10 mm"), std::string::npos) << error;
  EXPECT_NE(error.find("Give 'pad' control_points >= "), std::string::npos) << error;
  const int suggested = std::stoi(error.substr(error.find(">= ") + 3));
  EXPECT_GT(suggested, 60);
  // one fewer is refused; the suggestion, two-pass contact, and the pad's own 6,000 points' worth build
  {
    Scene fewer;
    BuiltScene fewer_built;
    ASSERT_TRUE(LoadSceneFromString(BallOnPad(suggested - 1, false), "t.yaml", &fewer, &errors));
    EXPECT_FALSE(BuildScene(fewer, &fewer_built, &error));
  }
  for (const std::string& ok : {BallOnPad(suggested, false), BallOnPad(60, true), BallOnPad(800, false)}) {
    Scene fine;
    BuiltScene fine_built;
    ASSERT_TRUE(LoadSceneFromString(ok, "t.yaml", &fine, &errors)) << (errors.empty() ? "" : errors[0].Format());
    EXPECT_TRUE(BuildScene(fine, &fine_built, &error)) << error;
  }
  // a curved emitter bulges between its points as well: a 3 cm ball of control points
  // under the 1 cm one is a relative radius of 1 / (1/10 + 1/30) mm
  std::string ball_pad = BallOnPad(60, false);
  ball_pad.replace(ball_pad.find("{type: box, size_m: [0.06, 0.06, 0.01]}"), 39, "{type: sphere, radius_m: 0.03}");
  ball_pad.replace(ball_pad.find("position_m: [0, 0, -0.005]"), 26, "position_m: [0, 0, -0.03]");
  Scene curved;
  BuiltScene curved_built;
  ASSERT_TRUE(LoadSceneFromString(ball_pad, "t.yaml", &curved, &errors)) << (errors.empty() ? "" : errors[0].Format());
  EXPECT_FALSE(BuildScene(curved, &curved_built, &error));
  EXPECT_NE(error.find("relative curvature radius 7.5 mm"), std::string::npos) << error;
}

TEST(SceneFile, IllPosedMechanicsAreRefusedWithTheirPosition) {
  // zero, negative, NaN and infinite masses of a free body
  const std::string base = kMinimal;
  const size_t mass = base.find("0.05\n");
  ExpectError(std::string(base).replace(mass, 4, "0"), 13, 14, "out of range: expected a number in (0,");
  ExpectError(std::string(base).replace(mass, 4, "-1"), 13, 14, "out of range");
  ExpectError(std::string(base).replace(mass, 4, ".inf"), 13, 14, "finite number");
  ExpectError(std::string(base).replace(mass, 4, "-.inf"), 13, 14, "finite number");
  ExpectError(std::string(base).replace(mass, 4, ".NaN"), 13, 14, "finite number");
  // NaN and Inf in lists and nested maps
  ExpectError(std::string(base).replace(base.find("[0, 0, 0.0102]"), 14, "[0, .nan, 0.0102]"), 12, 21, "finite");
  ExpectError(WithBall("    damping: {linear_N_s_m: .inf}\n"), 14, 29, "finite");
  ExpectError(WithBall("    deformation: {model: gaussian, stiffness_N_m: .inf, influence_radius_m: 0.002}\n"), 14, 51,
              "finite");
  ExpectError(WithBall("    deformation: {model: gaussian, stiffness_N_m: 0, influence_radius_m: 0.002}\n"), 14, 51,
              "out of range");
  ExpectError(WithBall("    deformation: {model: gaussian, stiffness_N_m: 100, damping_N_s_m: -1, influence_radius_m: 0.002}\n"),
              14, 71, "out of range");
  ExpectError(WithBall("    deformation: {model: boussinesq, young_modulus_Pa: 1e5, poisson_ratio: 0.5}\n"), 14, 76,
              "out of range");
  ExpectError(std::string(kMinimal) + "gravity_m_s2: [0, 0, .inf]\n", 14, 22, "finite");
  ExpectError(std::string(kMinimal) + "solver: {tolerance: 0}\n", 14, 21, "out of range");
  ExpectError(std::string(kMinimal) + "solver: {over_relaxation: 2}\n", 14, 27, "out of range");
  ExpectError(std::string(kMinimal) + "solver: {anderson_depth: 9}\n", 14, 26, "out of range");
  ExpectError(std::string(kMinimal) + "friction: {pairs: [{a: ball, b: table, mu: -0.2}]}\n", 14, 44, "out of range");
  ExpectError(std::string(kMinimal) + "friction: {pairs: [{a: ball, b: table, mu: .nan}]}\n", 14, 44, "finite");
  // inertia: shape, positive definiteness, a rigid body's triangle inequality, only for free inertial bodies
  ExpectError(WithBall("    inertia_kg_m2: [1e-6, 1e-6]\n"), 14, 20, "list of 3");
  ExpectError(WithBall("    inertia_kg_m2: [1e-6, 1e-6, 0]\n"), 14, 20, "not positive definite");
  ExpectError(WithBall("    inertia_kg_m2: [1e-6, 1e-6, -1e-6]\n"), 14, 20, "not positive definite");
  ExpectError(WithBall("    inertia_kg_m2: [1e-6, 1e-6, 1e-6, 2e-6, 0, 0]\n"), 14, 20, "not positive definite");
  ExpectError(WithBall("    inertia_kg_m2: [1e-6, 1e-6, 3e-6]\n"), 14, 20, "exceeds the sum");
  ExpectError(WithBall("    inertia_kg_m2: [1e-6, 1e-6, .nan]\n"), 14, 33, "finite");
  ExpectError(WithBall("    dynamics: quasi_static\n    damping: {linear_N_s_m: 1, angular_N_m_s_rad: 1}\n"
                       "    inertia_kg_m2: [1e-6, 1e-6, 1e-6]\n"),
              16, 20, "only for free inertial");
  // quasi-static: damping or drive gains on every axis
  ExpectError(WithBall("    dynamics: quasi_static\n"), 14, 15, "needs positive damping");
  ExpectError(WithBall("    dynamics: quasi_static\n    damping: {linear_N_s_m: 1}\n"), 14, 15, "rotation about axis x");
  ExpectError(WithBall("    dynamics: quasi_static\n    damping: {angular_N_m_s_rad: 1}\n"
                       "    drive: {stiffness_N_m: [10, 10, 0]}\n"),
              14, 15, "translation about axis z");
  // a script map keyed by a list
  ExpectError(std::string(kMinimal) + "script:\n  - {time_s: 0.5, body_targets: {[a]: {position_m: [0, 0, 0]}}}\n", 15,
              34, "must map names");
}

TEST(SceneFile, WellPosedQuasiStaticAndInertiaLoad) {
  Scene s;
  std::vector<SceneError> errors;
  ASSERT_TRUE(LoadSceneFromString(WithBall("    inertia_kg_m2: [2e-6, 3e-6, 4e-6, 1e-7, 0, 0]\n"), "t.yaml", &s, &errors))
      << errors[0].Format();
  EXPECT_DOUBLE_EQ(s.bodies[1].spec.inertia(0, 1), 1e-7);
  BuiltScene built;
  std::string error;
  ASSERT_TRUE(BuildScene(s, &built, &error)) << error;
  EXPECT_DOUBLE_EQ(built.world.bodies[1].inertia(2, 2), 4e-6);
  Scene q;
  ASSERT_TRUE(LoadSceneFromString(WithBall("    dynamics: quasi_static\n    damping: {angular_N_m_s_rad: 1}\n"
                                           "    drive: {stiffness_N_m: [10, 10, 10]}\n"),
                                  "t.yaml", &q, &errors))
      << errors[0].Format();
}

TEST(SceneFile, BandwidthOutsideItsRangeOfSpacingsIsRefusedAtBuild) {
  for (const char* h : {"0.00001", "0.05"}) {
    Scene s;
    std::vector<SceneError> errors;
    ASSERT_TRUE(LoadSceneFromString(WithBall(std::string("    kernel_bandwidth_m: ") + h + "\n"), "t.yaml", &s, &errors));
    BuiltScene built;
    std::string error;
    EXPECT_FALSE(BuildScene(s, &built, &error)) << h;
    EXPECT_EQ(error.rfind("t.yaml:14:25: body 'ball': 'kernel_bandwidth_m'", 0), 0u) << error;
    EXPECT_NE(error.find("mean point spacing"), std::string::npos) << error;
  }
  Scene ok;
  std::vector<SceneError> errors;
  ASSERT_TRUE(LoadSceneFromString(WithBall("    kernel_bandwidth_m: 0.002\n"), "t.yaml", &ok, &errors));
  BuiltScene built;
  std::string error;
  EXPECT_TRUE(BuildScene(ok, &built, &error)) << error;
}

TEST(SceneFile, StructureErrors) {
  ExpectError("scene: t\ntimestep_s: 0.001\nduration_s: 1\nbodies: [\n", 5, 1, "syntax");
  ExpectError(std::string(kMinimal) + "timestep_s: 0.002\n", 14, 1, "duplicate key 'timestep_s'");
  const std::vector<SceneError> missing = Errors("scene: t\nduration_s: 1\nbodies: []\n");
  ASSERT_GE(missing.size(), 2u);  // every problem at once
  EXPECT_NE(missing[0].message.find("timestep_s"), std::string::npos);
  std::string pair = kMinimal;
  pair += "friction: {pairs: [{a: ball, b: nothing, mu: 0.5}]}\n";
  EXPECT_NE(Errors(pair).back().message.find("unknown body 'nothing'"), std::string::npos);
  std::string script = kMinimal;
  script += "script:\n  - {time_s: 0.5}\n  - {time_s: 0.2}\n";
  ExpectError(script, 16, 5, "increase");
  std::string mesh = std::string(kMinimal).replace(std::string(kMinimal).find("{type: sphere, radius_m: 0.01}"), 30,
                                                   "{type: mesh, file: no_such_file.obj}");
  ExpectError(mesh, 9, 31, "does not exist");
  std::string plane = std::string(kMinimal).replace(std::string(kMinimal).find("    motion: fixed"), 17, "    motion: free");
  const std::vector<SceneError> pe = Errors(plane);
  ASSERT_FALSE(pe.empty());
  EXPECT_NE(pe[0].message.find("plane must have"), std::string::npos);
}

TEST(SceneFile, DamagedFilesNeverCrash) {
  std::mt19937 rng(1);
  const std::string base = kMinimal;
  for (int i = 0; i < 400; ++i) {
    std::string t = base;
    if (i % 2 == 0) {
      t.resize(rng() % t.size());
    } else {
      for (int k = 0; k < 3; ++k) t[rng() % t.size()] = static_cast<char>(rng() % 128);
    }
    Scene s;
    std::vector<SceneError> errors;
    const bool ok = LoadSceneFromString(t, "t.yaml", &s, &errors);
    EXPECT_TRUE(ok || !errors.empty());
  }
}

// angular_velocity_rad_s starts a body spinning: a ball in free fall spinning at 20
// rad/s about x turns 20 x 0.1 rad in 0.1 s (no contact, nothing else acting on the spin)
TEST(SceneFile, AngularVelocityStartsTheBodySpinning) {
  const std::string text = R"(scene: t
timestep_s: 0.001
duration_s: 1.0
bodies:
  - name: ball
    shape: {type: sphere, radius_m: 0.01}
    points: 500
    control_points: 60
    position_m: [0, 0, 1.0]
    velocity_m_s: [0.1, 0, 0]
    angular_velocity_rad_s: [20, 0, 0]
    mass_kg: 0.05
)";
  Scene s;
  std::vector<SceneError> errors;
  ASSERT_TRUE(LoadSceneFromString(text, "t.yaml", &s, &errors)) << (errors.empty() ? "" : errors[0].Format());
  EXPECT_DOUBLE_EQ(s.bodies[0].spec.angular_velocity.x(), 20.0);
  BuiltScene built;
  std::string error;
  ASSERT_TRUE(BuildScene(s, &built, &error)) << error;
  World& w = built.world;
  for (int i = 0; i < 100; ++i) w.Step();
  const Eigen::AngleAxisd turned(w.bodies[0].pose.R);
  EXPECT_NEAR(turned.angle(), 2.0, 1e-9);
  EXPECT_NEAR(turned.axis().x(), 1.0, 1e-12);
  EXPECT_NEAR(w.bodies[0].angular_velocity.x(), 20.0, 1e-9);
  EXPECT_NEAR(w.bodies[0].pose.t.x(), 0.01, 1e-12);  // and it flew on at 0.1 m/s
  // a spin the step cannot follow is refused like a velocity it cannot: a 2 cm ball at
  // 2,000 rad/s moves its surface 20 mm a step
  std::string fast = text;
  fast.replace(fast.find("[20, 0, 0]"), 10, "[2000, 0, 0]");
  Scene spun;
  ASSERT_TRUE(LoadSceneFromString(fast, "t.yaml", &spun, &errors));
  BuiltScene refused;
  std::vector<SceneError> build_errors;
  EXPECT_FALSE(BuildScene(spun, &refused, &build_errors));
  ASSERT_FALSE(build_errors.empty());
  EXPECT_EQ(build_errors[0].line, 2) << build_errors[0].Format();  // timestep_s
  EXPECT_NE(build_errors[0].message.find("time step 0.001 s is too long: body 'ball'"), std::string::npos)
      << build_errors[0].Format();
}

}  // namespace
}  // namespace gs::app
