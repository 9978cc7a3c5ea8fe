// A synthetic DTrack Fingertracking hand for demos, tests and benchmarks: a
// right hand (thumb, index, middle) that reaches down for the paper's box (a
// 6 cm cube on a table, centred at (0, 0, 30) mm in a Z-up room), closes on
// its sides, lifts it 5 cm, holds it and releases it. Each datagram is what a
// DTrack2 controller sends: fr, ts, 6dcal, 6d, glcal and gl lines (tips in the
// hand frame), CR LF line ends.
//
// With `whole_hand`, a five-finger (or three-finger) hand whose every phalanx is
// consistent with the gl block it sends (core/hand.h): palm down over the box, it
// comes down until the palm is 1 mm above the lid, closes the four fingers over
// the far face (+x) and the thumb on the near one (-x), both `squeeze_mm` into
// the faces, lifts the box `lift_mm`, holds it `hold_s`, opens and rises. With
// `pinch`, a precision pinch instead: the palm 5 mm over the lid, the index's and
// the thumb's outer phalanges on the far and near faces, the other fingers stretched.
// A left whole hand is the right one mirrored in the room's y (the box is centred on
// y = 0): the same grasp, the thumb on the other side.
#pragma once

#include <cstdint>
#include <string>

#include "core/hand.h"
#include "core/types.h"
#include "tracking/tracker_config.h"

namespace gs::tracking {

struct SyntheticHand {
  Vec3 box_center_mm = Vec3(0, 0, 30);
  double box_half_mm = 30.0;
  double tip_radius_mm = 8.0;
  double squeeze_mm = 4.0;     ///< closed targets lie this far inside the faces
  double open_mm = 24.0;       ///< extra distance from the faces when open
  double lift_mm = 50.0;
  double reach_mm = 80.0;      ///< start height above the grasp height
  int fingers = 3;             ///< 3 or 5 (ring and little trail behind)
  double duration_s = 2.9;
  bool whole_hand = false;     ///< every phalanx and the palm (see above); duration_s is then 2.8 s + hold_s
  double hold_s = 3.0;         ///< whole hand: the hold with the box lifted
  bool pinch = false;          ///< whole hand: a precision pinch (thumb and index tips) instead of the power grasp
  double size_scale = 1.0;     ///< whole hand: the average adult hand's phalanx lengths and fingertip radii times this
  bool right = true;           ///< whole hand: false sends a left hand (gl's lr 0), the right one mirrored in the room's y

  /// A whole hand of `fingers` fingers (duration_s set from hold_s).
  static SyntheticHand WholeHand(int fingers, double hold_s);
  /// Whole hand at time t: the back of the hand and each finger, room frame, m.
  void WholeHandPose(double t, Pose* hand, TrackedFinger* out) const;

  /// The tips (thumb, index, middle, ring, little) at time t: room mm.
  void Tips(double t, Vec3* tips) const;
  /// Back-of-hand pose at time t (room mm).
  Pose HandPose(double t) const;
  /// The datagram of frame number `frame` at time t (s from the start).
  std::string Datagram(double t, uint32_t frame) const;
};

/// The synthetic hand that drives a scene's tracker: the whole hand (power grasp)
/// when it follows a tracked hand's segments, with its number of fingers and its
/// side (a left hand for a scene's `side: left`); else
/// the fingertips' hand, with five fingers when it follows ring or little.
SyntheticHand SyntheticHandFor(const TrackerConfig& c);

}  // namespace gs::tracking
