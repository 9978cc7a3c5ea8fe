#include "tracking/hand_mapping.h"

#include <algorithm>

namespace gs::tracking {

Mat3 UpAxisRotation(EUpAxis up) {
  if (up == EUpAxis::Z) return Mat3::Identity();
  // Powerwall: x long arm, y up, -z short arm -> world x, z up, y = -z_room
  Mat3 R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  return R;
}

Pose RoomToWorld(const TrackerConfig& c, const Vec3& room_position, const Mat3& room_rotation) {
  const Mat3 U = UpAxisRotation(c.up);
  const Pose z_up{U * room_rotation, U * room_position * c.units_m};
  return c.calibration * z_up;
}

void MapFrame(const DTrackFrame& frame, const TrackerConfig& c, TargetSample* out) {
  out->frame = frame.frame;
  out->count = std::min(static_cast<int>(c.fingertips.size()), TargetSample::kMaxTips);
  const Hand* hand = c.source == ESource::Hand ? frame.FindHand(c.hand_id) : nullptr;
  for (int i = 0; i < out->count; ++i) {
    const FingertipMap& m = c.fingertips[i];
    out->valid[i] = false;
    Vec3 p;
    Mat3 R;
    if (c.source == ESource::Hand) {
      if (!hand || !hand->tracked() || m.finger < 0 || m.finger >= hand->num_fingers) continue;
      p = hand->fingers[m.finger].room_position;
      R = hand->fingers[m.finger].room_rotation;
    } else {
      const Body6d* b = frame.FindBody(m.body_id);
      if (!b || !b->tracked()) continue;
      p = b->position;
      R = b->rotation;
    }
    // the parser guarantees finite, orthonormal rotations on tracked objects;
    // re-orthonormalise the 6-decimal matrix so that the targets stay rotations
    const Quat q(R);
    if (!(q.norm() > 0.5)) continue;
    out->pose[i] = RoomToWorld(c, p, q.normalized().toRotationMatrix()) * m.offset;
    out->valid[i] = out->pose[i].t.allFinite() && out->pose[i].R.allFinite();
  }
}

}  // namespace gs::tracking
