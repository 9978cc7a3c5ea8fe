#include "scene/script.h"

#include <algorithm>

namespace gs::app {
namespace {

template <class T>
void Insert(std::vector<std::pair<double, T>>* keys, double t, const T& v) {
  auto it = std::lower_bound(keys->begin(), keys->end(), t,
                             [](const std::pair<double, T>& k, double x) { return k.first < x; });
  if (it != keys->end() && it->first == t) {
    it->second = v;
  } else {
    keys->insert(it, {t, v});
  }
}

// index of the last key at or before t (or 0), and the blend toward the next one
template <class T>
int Locate(const std::vector<std::pair<double, T>>& keys, double t, double* alpha) {
  *alpha = 0.0;
  if (keys.size() < 2 || t <= keys.front().first) return 0;
  if (t >= keys.back().first) return static_cast<int>(keys.size()) - 1;
  auto it = std::upper_bound(keys.begin(), keys.end(), t,
                             [](double x, const std::pair<double, T>& k) { return x < k.first; });
  const int i = static_cast<int>(it - keys.begin()) - 1;
  *alpha = (t - keys[i].first) / (keys[i + 1].first - keys[i].first);
  return i;
}

Vec3 LerpV(const Vec3& a, const Vec3& b, double s) { return a + s * (b - a); }
Vec4 LerpV(const Vec4& a, const Vec4& b, double s) { return a + s * (b - a); }
Pose LerpV(const Pose& a, const Pose& b, double s) {
  Pose p;
  p.t = a.t + s * (b.t - a.t);
  p.R = Quat(a.R).slerp(s, Quat(b.R)).normalized().toRotationMatrix();
  return p;
}

template <class T>
T Sample(const std::vector<std::pair<double, T>>& keys, double t) {
  double a;
  const int i = Locate(keys, t, &a);
  if (a <= 0.0 || i + 1 >= static_cast<int>(keys.size())) return keys[i].second;
  return LerpV(keys[i].second, keys[i + 1].second, a);
}

}  // namespace

void ScriptPlayer::SetHandPosition(double time, const Vec3& position) { Insert(&hand_, time, position); }

void ScriptPlayer::SetFingerJoints(int finger, double time, const Vec4& joints) {
  auto it = std::find_if(fingers_.begin(), fingers_.end(), [&](const Channel<Vec4>& c) { return c.index == finger; });
  if (it == fingers_.end()) {
    fingers_.push_back({finger, {}});
    it = fingers_.end() - 1;
  }
  Insert(&it->keys, time, joints);
}

void ScriptPlayer::SetBodyTarget(int body, double time, const Pose& pose) {
  auto it = std::find_if(bodies_.begin(), bodies_.end(), [&](const Channel<Pose>& c) { return c.index == body; });
  if (it == bodies_.end()) {
    bodies_.push_back({body, {}});
    it = bodies_.end() - 1;
  }
  Insert(&it->keys, time, pose);
}

void ScriptPlayer::Apply(World& w, double t) const {
  if (!hand_.empty()) w.hand.pose.t = Sample(hand_, t);
  for (const Channel<Vec4>& c : fingers_) {
    Finger& f = w.hand.fingers[c.index];
    f.q_target = ClampJoints(f.model, Sample(c.keys, t));
  }
  for (const Channel<Pose>& c : bodies_) {
    Body& b = w.bodies[c.index];
    const Pose p = Sample(c.keys, t);
    if (b.motion == EMotion::Kinematic) {
      b.pose = p;
    } else {
      b.drive.target = p;
    }
  }
}

}  // namespace gs::app
