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

ECarries JudgeFrame(const DTrackFrame& frame, int errors, const TrackerConfig& c, const TargetSample& sample,
                    int* missing_code) {
  *missing_code = 0;
  if (frame.present == 0 && errors == 0) return ECarries::NotDTrack;
  if (c.source == ESource::Hand && !frame.FindHand(c.hand_id)) {
    *missing_code = -1;
    return ECarries::Missing;
  }
  for (int i = 0; i < sample.count; ++i) {
    if (!sample.valid[i]) {
      *missing_code = i;
      return ECarries::Missing;
    }
  }
  return ECarries::Good;
}

std::string MissingLabel(const TrackerConfig& c, int missing_code) {
  if (c.source == ESource::Hand) {
    const std::string hand = "hand " + std::to_string(c.hand_id);
    if (missing_code < 0 || missing_code >= static_cast<int>(c.fingertips.size())) return hand;
    return "finger " + std::to_string(c.fingertips[missing_code].finger) + " of " + hand;
  }
  if (missing_code < 0 || missing_code >= static_cast<int>(c.fingertips.size())) return "the tracked bodies";
  return "body " + std::to_string(c.fingertips[missing_code].body_id);
}

}  // namespace gs::tracking
