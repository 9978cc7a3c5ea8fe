#include "tracking/target_follower.h"

#include <algorithm>

namespace gs::tracking {

const char* TipStateName(ETipState s) {
  switch (s) {
    case ETipState::Waiting: return "waiting";
    case ETipState::Tracking: return "tracking";
    case ETipState::Lost: return "lost";
    case ETipState::Released: return "released";
  }
  return "?";
}

void TargetFollower::Init(const TrackerConfig& config, const World& w) {
  config_ = config;
  dt_ = w.params.dt;
  tips_.assign(config.fingertips.size(), Tip());
  for (size_t i = 0; i < tips_.size(); ++i) {
    Tip& tip = tips_[i];
    tip.body = config.fingertips[i].body_index;
    if (tip.body >= 0 && tip.body < static_cast<int>(w.bodies.size())) tip.from = tip.to = tip.current = w.bodies[tip.body].pose;
  }
  last_push_ = -1.0;
  samples_ = 0;
}

Pose TargetFollower::Interpolated(const Tip& tip, double t, Vec3* velocity, Vec3* angular_velocity) const {
  const double end = tip.t0 + tip.duration;
  // the target's mean velocities over the step ending at t: the blend's times the
  // part of (t - dt, t] it moves in. The step that ends as the blend reaches its
  // sample moves all the way (zero there would drop the couplings' damping
  // feed-forward once every sample interval, a jerk at the tracker's rate)
  const double moving = std::clamp(std::min(t, end) - std::max(t - dt_, tip.t0), 0.0, dt_);
  if (tip.duration > 0.0) {
    const double f = moving / (dt_ * tip.duration);
    *velocity = tip.shift * f;
    *angular_velocity = tip.turn * f;
  } else {
    velocity->setZero();
    angular_velocity->setZero();
  }
  if (!(tip.duration > 0.0) || t >= end) return tip.to;
  const double s = std::clamp((t - tip.t0) / tip.duration, 0.0, 1.0);
  Pose p;
  p.t = tip.from.t + s * (tip.to.t - tip.from.t);
  p.R = Quat(tip.from.R).slerp(s, Quat(tip.to.R)).normalized().toRotationMatrix();
  return p;
}

void TargetFollower::Push(const TargetSample& s, double t) {
  ++samples_;
  // the blend lasts the measured interval between samples, within [dt, max]
  double duration = 0.0;
  if (config_.interpolate && last_push_ >= 0.0)
    duration = std::clamp(t - last_push_, dt_, std::max(dt_, config_.max_interpolation_s));
  last_push_ = t;
  for (size_t i = 0; i < tips_.size(); ++i) {
    Tip& tip = tips_[i];
    const bool valid = static_cast<int>(i) < s.count && s.valid[i];
    if (!valid) {
      // hold the target reached so far
      if (tip.state == ETipState::Tracking) {
        Vec3 v, omega;
        tip.to = tip.from = Interpolated(tip, t, &v, &omega);
        tip.duration = 0.0;
        tip.state = ETipState::Lost;
      }
      continue;
    }
    Vec3 v, omega;
    // from where the target is now (a released fingertip: from where the body is)
    tip.from = tip.state == ETipState::Released ? tip.current : Interpolated(tip, t, &v, &omega);
    tip.to = s.pose[i];
    tip.shift = tip.to.t - tip.from.t;
    const Eigen::AngleAxisd turn(tip.to.R * tip.from.R.transpose());  // the blend's rotation (world)
    tip.turn = turn.axis() * turn.angle();
    tip.t0 = t;
    tip.duration = tip.state == ETipState::Waiting ? 0.0 : duration;
    tip.last_valid = t;
    tip.state = ETipState::Tracking;
  }
}

void TargetFollower::Apply(World& w, double t) {
  for (Tip& tip : tips_) {
    if (tip.body < 0) continue;
    Body& b = w.bodies[tip.body];
    if ((tip.state == ETipState::Tracking || tip.state == ETipState::Lost) &&
        t - tip.last_valid > config_.lost_timeout_s)
      tip.state = ETipState::Released;
    if (tip.state == ETipState::Released) {
      ReleaseCoupling(b, w.params.gravity, config_.coupling);
      tip.current = b.pose;
      tip.velocity.setZero();
      tip.angular_velocity.setZero();
      continue;
    }
    tip.current = Interpolated(tip, t, &tip.velocity, &tip.angular_velocity);
    SetCouplingTarget(b, w.params.gravity, config_.coupling, tip.current, tip.velocity, tip.angular_velocity);
  }
}

}  // namespace gs::tracking
