#include "session/tracked_sim.h"

#include <cstdio>

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

void TrackedSim::HudText(char* buf, size_t size) const {
  if (size == 0) return;
  const int n = follower_.size();
  int tracking = 0;
  for (int i = 0; i < n; ++i) tracking += follower_.state(i) == tracking::ETipState::Tracking;
  int len = std::snprintf(buf, size, "%d/%d tracking", tracking, n);
  const auto& tips = scene_->tracker.fingertips;
  bool first = true;
  for (int i = 0; i < n && len >= 0 && static_cast<size_t>(len) < size; ++i) {
    if (follower_.state(i) == tracking::ETipState::Tracking) continue;
    len += std::snprintf(buf + len, size - static_cast<size_t>(len), "%s %s %s", first ? ";" : ",",
                         i < static_cast<int>(tips.size()) ? tips[i].name.c_str() : "?",
                         tracking::TipStateName(follower_.state(i)));
    first = false;
  }
}

void TrackedSim::Step() {
  World& w = world();
  if (!scene_->script.empty()) scene_->script.Apply(w, w.time + w.params.dt);
  follower_.Apply(w, w.time + w.params.dt);
  w.Step();
}

}  // namespace gs::app
