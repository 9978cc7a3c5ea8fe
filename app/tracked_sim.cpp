#include "app/tracked_sim.h"

namespace gs::app {

bool TrackedSim::Load(const std::string& path, std::string* error) {
  scene_ = std::make_unique<BuiltScene>();
  if (!LoadAndBuildScene(path, scene_.get(), error)) return false;
  if (!scene_->has_tracker) {
    *error = path + ": the scene has no 'tracker:' section (see docs/tracking.md and config/tracked_hand.yaml)";
    return false;
  }
  follower_.Init(scene_->tracker, scene_->world);
  return true;
}

void TrackedSim::Ingest(const char* data, size_t size, bool truncated, tracking::TargetSample* out) {
  int errors = 0;
  if (truncated) {
    parser_.CountOversized(size);
    frame_.Clear();
    errors = 1;
  } else {
    errors = parser_.Parse(data, size, &frame_);
  }
  MapFrame(frame_, scene_->tracker, out);
  out->parse_errors = errors;
}

void TrackedSim::Step() {
  World& w = world();
  if (!scene_->script.empty()) scene_->script.Apply(w, w.time + w.params.dt);
  follower_.Apply(w, w.time + w.params.dt);
  w.Step();
}

}  // namespace gs::app
