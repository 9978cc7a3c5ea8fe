// From a parsed DTrack frame to fingertip target poses in the world: a gl hand's
// fingertips (composed from the hand frame by the parser) or one 6d body per
// fingertip; the room's up axis turned to the world's Z, millimetres to metres,
// the calibration pose (world from room) and each fingertip's offset.
#pragma once

#include <cstdint>
#include <string>

#include "core/hand.h"
#include "tracking/dtrack_parser.h"
#include "tracking/tracker_config.h"

namespace gs::tracking {

/// Fingertip targets from one datagram (or a whole hand's segment targets: the
/// palm and three phalanges per finger): fixed size, so that it crosses the
/// mailbox without allocating.
struct TargetSample {
  static constexpr int kMaxTips = 16;
  int64_t arrival_ns = 0;     ///< receiver's steady clock (live) or recorded arrival (replay)
  uint64_t sequence = 0;      ///< datagram number at the receiver
  uint32_t frame = 0;         ///< DTrack frame counter (0 when the datagram had no fr line)
  int parse_errors = 0;       ///< lines dropped from this datagram
  int count = 0;
  bool valid[kMaxTips] = {};  ///< false: not tracked (quality -1 or absent)
  Pose pose[kMaxTips];        ///< world, m
};

/// Rotation taking room coordinates to a Z-up frame.
Mat3 UpAxisRotation(EUpAxis up);

/// World pose of a tracked pose given in room units.
Pose RoomToWorld(const TrackerConfig& c, const Vec3& room_position, const Mat3& room_rotation);

/// The tracked finger a gl finger block gives (room frame, tracker units, angles
/// in radians), or why it cannot be a finger: an outer phalanx orientation that
/// is not a rotation, or core FingerProblem with lengths outside
/// [min_phalanx_m, max_phalanx_m]. The check MapFrame applies to every phalanx target.
const char* GlFinger(const HandFinger& f, const TrackerConfig& c, TrackedFinger* out);

/// Fills `out` (count, valid, pose) from a parsed frame. A phalanx target is the
/// capsule pose of that phalanx (core/hand.h) in the chain the gl finger gives; a
/// finger whose block cannot be a finger (core FingerProblem: lengths outside
/// [min_phalanx_m, max_phalanx_m], non-finite values) leaves its targets not valid,
/// as does a hand of the wrong side (hand_side).
void MapFrame(const DTrackFrame& frame, const TrackerConfig& c, TargetSample* out);

/// What a datagram carries for the scene (tracker health, docs/tracking.md).
enum class ECarries {
  Good,       ///< every fingertip's hand or body, tracked
  NotDTrack,  ///< no DTrack line at all and no parse error (random bytes, another protocol)
  Missing,    ///< DTrack, but a needed hand or body is absent or untracked (DTrack lists tracked ones only)
};

/// Judges a parsed datagram (`errors`: the parser's count for it) and the sample
/// MapFrame made of it. With Missing, *missing_code says what is missing first: -1 the
/// hand itself (source hand), else the fingertip index (its finger or body).
ECarries JudgeFrame(const DTrackFrame& frame, int errors, const TrackerConfig& c, const TargetSample& sample,
                    int* missing_code);

/// What a good datagram carries for the scene: "hand 0 (right)", "bodies 1, 2".
std::string NeedsLabel(const TrackerConfig& c);

/// True when the frame holds the scene's hand (its id) but of the other side: a left
/// glove where the scene has `side: right`, or the other way round. Such a hand
/// drives nothing (MapFrame); the commands say so, naming the scene's `side`.
bool CarriesOtherSide(const DTrackFrame& frame, const TrackerConfig& c);

/// "hand 0", "finger 4 of hand 0", "body 3": what a missing code names.
std::string MissingLabel(const TrackerConfig& c, int missing_code);

}  // namespace gs::tracking
