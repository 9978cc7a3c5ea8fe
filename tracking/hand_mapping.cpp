#include "tracking/hand_mapping.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/hand.h"

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

namespace {

// the tracked pose (room units) of a hand's target: its fingertip, the back of the
// hand, or a phalanx of the chain the finger's block gives; false when it has none
bool SegmentPose(const Hand& hand, const FingertipMap& m, const TrackerConfig& c, Vec3* p, Mat3* R) {
  if (m.segment == ESegment::Palm) {
    *p = hand.position;
    *R = hand.rotation;
    return true;
  }
  if (m.finger < 0 || m.finger >= hand.num_fingers) return false;
  const HandFinger& f = hand.fingers[m.finger];
  if (m.segment == ESegment::Tip) {
    if (!(Quat(f.room_rotation).norm() > 0.5)) return false;
    *p = f.room_position;
    *R = f.room_rotation;
    return true;
  }
  TrackedFinger tf;
  if (GlFinger(f, c, &tf)) return false;
  const EPhalanx k = m.segment == ESegment::Outer ? EPhalanx::Outer
                     : m.segment == ESegment::Middle ? EPhalanx::Middle : EPhalanx::Inner;
  const Pose seg = PhalanxCapsulePose(ChainFromTip(tf), k);
  *p = seg.t;
  *R = seg.R;
  return true;
}

}  // namespace

const char* GlFinger(const HandFinger& f, const TrackerConfig& c, TrackedFinger* out) {
  const Quat q(f.room_rotation);
  if (!(q.norm() > 0.5)) return "the outer phalanx's orientation is not a rotation";
  out->tip = Pose{q.normalized().toRotationMatrix(), f.room_position};
  out->tip_radius = f.tip_radius;
  for (int k = 0; k < kPhalanges; ++k) out->length[k] = f.phalanx_length[k];
  for (int k = 0; k < 2; ++k) out->angle[k] = f.phalanx_angle[k] * (M_PI / 180.0);
  return FingerProblem(*out, c.min_phalanx_m / c.units_m, c.max_phalanx_m / c.units_m);
}

void MapFrame(const DTrackFrame& frame, const TrackerConfig& c, TargetSample* out) {
  out->frame = frame.frame;
  out->count = std::min(static_cast<int>(c.fingertips.size()), TargetSample::kMaxTips);
  // a hand of the other side (a left glove where the scene has a right hand) drives nothing
  const Hand* hand =
      c.source == ESource::Hand && !CarriesOtherSide(frame, c) ? frame.FindHand(c.hand_id) : nullptr;
  for (int i = 0; i < out->count; ++i) {
    const FingertipMap& m = c.fingertips[i];
    out->valid[i] = false;
    Vec3 p;
    Mat3 R;
    if (c.source == ESource::Hand) {
      if (!hand || !hand->tracked() || !SegmentPose(*hand, m, c, &p, &R)) continue;
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
  if (c.source == ESource::Hand && (!frame.FindHand(c.hand_id) || CarriesOtherSide(frame, c))) {
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

std::string NeedsLabel(const TrackerConfig& c) {
  if (c.source == ESource::Hand) return MissingLabel(c, -1);
  std::string s = "bodies";
  for (size_t i = 0; i < c.fingertips.size(); ++i) s += (i ? ", " : " ") + std::to_string(c.fingertips[i].body_id);
  return s;
}

bool CarriesOtherSide(const DTrackFrame& frame, const TrackerConfig& c) {
  if (c.source != ESource::Hand || c.hand_side < 0) return false;
  const Hand* hand = frame.FindHand(c.hand_id);
  return hand && hand->right != (c.hand_side == 1);
}

std::string MissingLabel(const TrackerConfig& c, int missing_code) {
  if (c.source == ESource::Hand) {
    const std::string hand = "hand " + std::to_string(c.hand_id);
    if (missing_code < 0 || missing_code >= static_cast<int>(c.fingertips.size()))
      return c.hand_side < 0 ? hand : hand + (c.hand_side == 1 ? " (right)" : " (left)");
    const FingertipMap& m = c.fingertips[missing_code];
    if (m.finger < 0) return "the palm of " + hand;
    const std::string finger = "finger " + std::to_string(m.finger) + " of " + hand;
    if (m.segment == ESegment::Tip) return finger;
    // a phalanx has no target also when the finger's block cannot be a finger (MapFrame)
    char range[96];
    std::snprintf(range, sizeof(range), " (or its gl block with a phalanx length or radius outside %g to %g mm)",
                  1e3 * c.min_phalanx_m, 1e3 * c.max_phalanx_m);
    return finger + range;
  }
  if (missing_code < 0 || missing_code >= static_cast<int>(c.fingertips.size())) return "the tracked bodies";
  return "body " + std::to_string(c.fingertips[missing_code].body_id);
}

}  // namespace gs::tracking
