#include "app/scene_file.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace gs::app
