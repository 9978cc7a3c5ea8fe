// The scene file's tracker section: what it reads and what it refuses.
#include <gtest/gtest.h>

#include "scene/scene_file.h"

namespace gs::app {
namespace {

const char* kBase = R"(scene: t
timestep_s: 0.001
duration_s: 1.0
bodies:
  - name: table
    shape: {type: plane}
    motion: fixed
  - name: tip
    shape: {type: sphere, radius_m: 0.008}
    points: 200
    control_points: 30
    position_m: [0, 0, 0.1]
    mass_kg: 0.02
)";

bool Load(const std::string& tracker, Scene* s, std::vector<SceneError>* errors) {
  return LoadSceneFromString(std::string(kBase) + tracker, "t.yaml", s, errors);
}

std::string FirstError(const std::string& tracker) {
  Scene s;
  std::vector<SceneError> errors;
  EXPECT_FALSE(Load(tracker, &s, &errors)) << tracker;
  std::string all;
  for (const SceneError& e : errors) all += e.Format() + "\n";
  return all;  // every error, the first one first
}

TEST(SceneTracker, ReadsEveryKey) {
  Scene s;
  std::vector<SceneError> errors;
  ASSERT_TRUE(Load(R"(tracker:
  port: 5001
  multicast_group: 224.0.1.0
  allowed_senders: [192.168.0.10, 10.0.0.2]
  controller: 192.168.0.10
  source: bodies
  room_up: y
  units_m: 0.001
  calibration: {position_m: [1, 2, 3], rotation_deg: [0, 0, 90]}
  lost_timeout_s: 0.25
  interpolate: false
  coupling: {stiffness_N_m: 500, damping_N_s_m: 5, max_force_N: 10, max_torque_N_m: 0.1}
  fingertips:
    - {name: index, body: tip, body_id: 3, offset_m: [0, 0, 0.01]}
  publish: {rate_hz: 50, lcm_url: "udpm://239.255.76.67:7668?ttl=0"}
)",
                   &s, &errors))
      << errors[0].Format();
  ASSERT_TRUE(s.has_tracker);
  const tracking::TrackerConfig& c = s.tracker;
  EXPECT_EQ(c.port, 5001);
  EXPECT_EQ(c.multicast_group, "224.0.1.0");
  EXPECT_EQ(c.allowed_senders.size(), 2u);
  EXPECT_EQ(c.controller, "192.168.0.10");
  EXPECT_EQ(c.source, tracking::ESource::Bodies);
  EXPECT_EQ(c.up, tracking::EUpAxis::Y);
  EXPECT_EQ(c.calibration.t, Vec3(1, 2, 3));
  EXPECT_NEAR(c.calibration.R(1, 0), 1.0, 1e-12);
  EXPECT_EQ(c.lost_timeout_s, 0.25);
  EXPECT_FALSE(c.interpolate);
  EXPECT_EQ(c.coupling.stiffness, 500);
  EXPECT_EQ(c.coupling.max_force, 10);
  ASSERT_EQ(c.fingertips.size(), 1u);
  EXPECT_EQ(c.fingertips[0].body_id, 3);
  EXPECT_EQ(c.fingertips[0].offset.t, Vec3(0, 0, 0.01));
  EXPECT_EQ(c.publish_rate_hz, 50);
  // built: the body index resolves
  BuiltScene b;
  std::string error;
  ASSERT_TRUE(BuildScene(s, &b, &error)) << error;
  EXPECT_EQ(b.tracker.fingertips[0].body_index, 1);
}

TEST(SceneTracker, RefusesWhatCannotWork) {
  EXPECT_NE(FirstError("tracker:\n  fingertips:\n    - {name: a, body: nope, finger: 0}\n").find("unknown body 'nope'"),
            std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  fingertips:\n    - {name: a, body: table, finger: 0}\n").find("must be a free body"),
            std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  fingertips:\n    - {name: a, body: tip, finger: 5}\n").find("finger"),
            std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  multicast_group: 10.0.0.1\n  fingertips:\n    - {name: a, body: tip, finger: 0}\n")
                .find("multicast"),
            std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  allowed_senders: [host.example]\n  fingertips:\n    - {name: a, body: tip, finger: 0}\n")
                .find("IPv4"),
            std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  port: 70000\n  fingertips:\n    - {name: a, body: tip, finger: 0}\n").find("port"),
            std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  room_up: x\n  fingertips:\n    - {name: a, body: tip, finger: 0}\n").find("room_up"),
            std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  fingertips:\n    - {name: a, body: tip, body_id: 0}\n").find("body_id"),
            std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  port: 5000\n").find("fingertips"), std::string::npos);
  EXPECT_NE(FirstError("tracker:\n  fingertips:\n    - {name: a, body: tip, finger: 0, colour: red}\n").find("colour"),
            std::string::npos);
  // file:line:column
  EXPECT_EQ(FirstError("tracker:\n  fingertips:\n    - {name: a, body: nope, finger: 0}\n").rfind("t.yaml:", 0), 0u);
}

TEST(SceneTracker, ShippedTrackedHandScene) {
  BuiltScene b;
  std::string error;
  ASSERT_TRUE(LoadAndBuildScene(std::string(GRASPSIM_SOURCE_DIR) + "/config/tracked_hand.yaml", &b, &error)) << error;
  ASSERT_TRUE(b.has_tracker);
  ASSERT_EQ(b.tracker.fingertips.size(), 3u);
  for (const auto& f : b.tracker.fingertips) {
    ASSERT_GE(f.body_index, 0);
    EXPECT_EQ(b.world.bodies[f.body_index].motion, EMotion::Free);
  }
  EXPECT_EQ(b.world.bodies[b.tracked_body].name, "box");
}

}  // namespace
}  // namespace gs::app
