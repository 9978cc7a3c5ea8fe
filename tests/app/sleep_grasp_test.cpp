// Sleep in the paper's grasp (config/paper_box_grasp.yaml, docs/skip.md): the
// box never sleeps while a fingertip touches it (the fingertips are driven, so
// they are awake movers whose bounding spheres keep it awake), nor do they.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "scene/scene_file.h"

namespace gs::app {
namespace {

std::unique_ptr<BuiltScene> Load(bool sleep) {
  auto s = std::make_unique<BuiltScene>();
  std::string error;
  EXPECT_TRUE(LoadAndBuildScene(std::string(GRASPSIM_SOURCE_DIR) + "/config/paper_box_grasp.yaml", s.get(), &error))
      << error;
  s->world.params.sleep.enabled = sleep;
  return s;
}

TEST(SleepGrasp, HeldBoxNeverSleepsWhileTheFingersMove) {
  auto on = Load(true);
  World& w = on->world;
  const int box = on->tracked_body;
  ASSERT_GE(box, 0);
  ASSERT_EQ(w.bodies[box].name, "box");
  // through the close, the lift (it ends at 0.9 s) and into the hold, where the
  // held box is still: only the fingertips being awake keep it awake there
  const int steps = 1200;
  int touched_steps = 0, asleep_steps = 0, asleep_while_touched = 0;
  for (int i = 0; i < steps; ++i) {
    on->script.Apply(w, w.time + w.params.dt);
    w.Step();
    ASSERT_FALSE(w.profile.rejected);
    bool touched = false;
    for (const ContactRow& r : w.rows) {
      const Body& a = w.bodies[r.contact.body[0]];
      const Body& b = w.bodies[r.contact.body[1]];
      touched |= (r.contact.body[0] == box && b.finger >= 0) || (r.contact.body[1] == box && a.finger >= 0);
    }
    touched_steps += touched;
    asleep_steps += w.bodies[box].asleep;
    asleep_while_touched += touched && w.bodies[box].asleep;
    // fingertips are driven: never asleep
    for (const Body& b : w.bodies) ASSERT_FALSE(b.finger >= 0 && b.asleep);
  }
  EXPECT_GT(touched_steps, 300);
  EXPECT_EQ(asleep_while_touched, 0);
  EXPECT_FALSE(w.bodies[box].asleep);
  EXPECT_GT(w.bodies[box].pose.t.z(), 0.0302 + 0.01) << "lifted";
  RecordProperty("asleep_steps", asleep_steps);
}

}  // namespace
}  // namespace gs::app
