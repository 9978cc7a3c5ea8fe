// A scene with a tracker section, made ready to follow DTrack input: the world,
// the parser, the mapping to fingertip targets and the target follower. Shared
// by replay (samples at their recorded times in simulated time), live (samples
// as they arrive, through the mailbox) and the tracking benchmark.
#pragma once

#include <memory>
#include <string>

#include "scene/scene_file.h"
#include "tracking/dtrack_parser.h"
#include "tracking/target_follower.h"

namespace gs::app {

class TrackedSim {
 public:
  /// Loads and builds the scene; it must have a tracker section.
  bool Load(const std::string& path, std::string* error);

  World& world() { return scene_->world; }
  const World& world() const { return scene_->world; }
  const BuiltScene& scene() const { return *scene_; }
  const tracking::TrackerConfig& config() const { return scene_->tracker; }
  tracking::TargetFollower& follower() { return follower_; }
  const tracking::TargetFollower& follower() const { return follower_; }
  const tracking::DTrackParser& parser() const { return parser_; }

  /// Parses one datagram and maps it to fingertip targets.
  void Ingest(const char* data, size_t size, bool truncated, tracking::TargetSample* out);

  /// Pushes a sample (applied from the current simulated time).
  void Push(const tracking::TargetSample& s) { follower_.Push(s, world().time); }

  /// Couplings toward the targets at the end of the step, then one step.
  void Step();

  /// The fingertips' states for a HUD, like "3/3 tracking" or "2/3 tracking;
  /// middle lost" (no allocation: writes into buf).
  void HudText(char* buf, size_t size) const;

 private:
  std::unique_ptr<BuiltScene> scene_;
  tracking::DTrackParser parser_;
  tracking::DTrackFrame frame_;
  tracking::TargetFollower follower_;
};

}  // namespace gs::app
