// Fingertips following their tracker targets in the simulation. Samples arrive
// at 60-300 Hz, the simulation steps at 1 kHz: a new sample is reached
// linearly (rotations by slerp) over the measured interval between samples,
// starting at the step it is pushed, so the force responds at once and the
// target moves without steps. A fingertip whose target is lost (quality -1 or
// absent) holds its last target; when no valid sample came for the scene's
// lost_timeout_s it releases (limp coupling: no spring). Before the first
// sample a fingertip holds its start pose. Deterministic: only the times
// passed in matter. No allocation after Init.
#pragma once

#include <vector>

#include "core/world.h"
#include "tracking/hand_mapping.h"

namespace gs::tracking {

enum class ETipState : int { Waiting = 0, Tracking = 1, Lost = 2, Released = 3 };
const char* TipStateName(ETipState s);

class TargetFollower {
 public:
  /// Resolves the fingertip bodies (FingertipMap::body_index) of the world; their start poses are held.
  void Init(const TrackerConfig& config, const World& w);

  /// A new sample, applied from simulated time t on.
  void Push(const TargetSample& s, double t);

  /// Sets every fingertip body's coupling for simulated time t (call before World::Step).
  void Apply(World& w, double t);

  int size() const { return static_cast<int>(tips_.size()); }
  ETipState state(int i) const { return tips_[i].state; }
  const Pose& target(int i) const { return tips_[i].current; }
  /// the target's mean velocity and angular velocity (world) over the step that
  /// ends at the last Apply's time
  const Vec3& velocity(int i) const { return tips_[i].velocity; }
  const Vec3& angular_velocity(int i) const { return tips_[i].angular_velocity; }
  int body(int i) const { return tips_[i].body; }
  uint64_t samples() const { return samples_; }

 private:
  struct Tip {
    int body = -1;
    ETipState state = ETipState::Waiting;
    Pose from, to, current;
    Vec3 shift = Vec3::Zero(), turn = Vec3::Zero();  ///< the blend's translation and rotation vector (world)
    double t0 = 0.0, duration = 0.0;
    double last_valid = -1e300;
    Vec3 velocity = Vec3::Zero(), angular_velocity = Vec3::Zero();
  };
  Pose Interpolated(const Tip& tip, double t, Vec3* velocity, Vec3* angular_velocity) const;

  TrackerConfig config_;
  std::vector<Tip> tips_;
  double last_push_ = -1.0;
  uint64_t samples_ = 0;
  double dt_ = 1e-3;
};

}  // namespace gs::tracking
