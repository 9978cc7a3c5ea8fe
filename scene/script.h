// Scripted scenes: keyframes for the hand position, the fingers' joint targets
// and the bodies' targets (drive targets of free bodies, poses of kinematic
// bodies). Every channel is interpolated linearly (rotations by slerp) between
// the keyframes that set it, and held before the first and after the last.
#pragma once

#include <vector>

#include "core/world.h"

namespace gs::app {

class ScriptPlayer {
 public:
  void SetHandPosition(double time, const Vec3& position);
  void SetFingerJoints(int finger, double time, const Vec4& joints);
  void SetBodyTarget(int body, double time, const Pose& pose);
  bool empty() const { return hand_.empty() && fingers_.empty() && bodies_.empty(); }
  /// The hand's keyframes (time, position), in time order.
  const std::vector<std::pair<double, Vec3>>& hand_keys() const { return hand_; }

  /// Applies every channel at simulated time t to the world's inputs.
  void Apply(World& w, double t) const;

 private:
  template <class T>
  struct Channel {
    int index = -1;
    std::vector<std::pair<double, T>> keys;
  };
  std::vector<std::pair<double, Vec3>> hand_;
  std::vector<Channel<Vec4>> fingers_;
  std::vector<Channel<Pose>> bodies_;
};

}  // namespace gs::app
