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
// A left whole hand is the right one mirrored in the room's y about the box's
// centre: the same grasp, the thumb on the other side.
//
// Aimed at another object (AimAt: SyntheticHandFor does it for a scene's tracked
// body), the hand grasps it where it lies and as large as it is: the fingertips
// close along x at its centre's height until each presses `squeeze_mm` into its
// surface; the whole hand's palm comes down to its top. A box (or a mesh, taken as its bounding box) is grasped on its faces
// as above; a curved one (sphere, ellipsoid, capsule, cylinder) is wrapped: each
// finger closes joint by joint, root first, until its phalanges press `squeeze_mm`
// into the surface, and the thumb's middle joint presses on its near side.
#pragma once

#include <cstdint>
#include <string>

#include "core/hand.h"
#include "core/sampling.h"
#include "core/types.h"
#include "tracking/tracker_config.h"

namespace gs::tracking {

/// The whole hand's open flexions (root, middle-inner, outer-middle; rad), every
/// finger's: where it starts and what it opens to.
inline Vec3 SyntheticOpenFlexion() { return Vec3(0.0, 0.35, 0.15); }

/// An object for the synthetic hand to grasp, in the room (m).
struct GraspObject {
  ShapeDesc shape;               ///< in its body frame; a mesh is grasped as its bounding box
  Pose pose;                     ///< the body frame in the room
  Vec3 low = Vec3::Zero(), high = Vec3::Zero();  ///< its bounding box along the room's axes
};

struct SyntheticHand {
  Vec3 box_center_mm = Vec3(0, 0, 30);  ///< the grasped object's bounding-box centre
  double box_half_mm = 30.0;            ///< its half extent along the room's x (the faces closed on)
  double box_half_width_mm = 30.0;      ///< along y
  double box_half_height_mm = 30.0;     ///< and along z: the whole hand's palm comes down to its top
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
  /// whole hand: a curved object to wrap (AimAt), in the room (m); unset: a box
  bool wrap = false;
  /// whole hand: a tall curved object is grasped from the side (AimAt)
  bool side_grasp = false;
  GraspObject object;
  /// the wrap's closed flexions per finger (root, middle-inner, outer-middle), set by AimAt
  Vec3 wrap_flexion[kHandMaxFingers] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  Vec3 wrap_thumb = Vec3::Zero();  ///< the wrap's thumb middle joint, closed (hand frame, m)
  Vec3 wrap_box = Vec3::Zero();    ///< the wrapped object's bounding-box centre (hand frame, m)

  /// fingertips: how far from the object's centre along x the thumb, index and
  /// middle tips close (mm; the box's faces unless aimed: AimAt)
  double tip_closed_mm[3] = {34.0, 34.0, 34.0};

  /// Grasps `o` where it lies (see above); call after choosing the hand (fingers, side, pinch, size_scale).
  void AimAt(const GraspObject& o);
  /// The fingertips' closed reach on `o` (AimAt does it): each tip `squeeze_mm` into
  /// the surface along x at its height and offset across.
  void AimTips(const GraspObject& o);

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
/// the fingertips' hand, with five fingers when it follows ring or little. With an
/// object (the scene's tracked body), aimed at it.
SyntheticHand SyntheticHandFor(const TrackerConfig& c);
SyntheticHand SyntheticHandFor(const TrackerConfig& c, const GraspObject& object);

}  // namespace gs::tracking
