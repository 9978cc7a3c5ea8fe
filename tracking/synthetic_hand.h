// A synthetic DTrack Fingertracking hand for demos, tests and benchmarks: a
// right hand (thumb, index, middle) that reaches down for the paper's box (a
// 6 cm cube on a table, centred at (0, 0, 30) mm in a Z-up room), closes on
// its sides, lifts it 5 cm, holds it and releases it. Each datagram is what a
// DTrack2 controller sends: fr, ts, 6dcal, 6d, glcal and gl lines (tips in the
// hand frame), CR LF line ends.
#pragma once

#include <cstdint>
#include <string>

#include "core/types.h"

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

  /// The tips (thumb, index, middle, ring, little) at time t: room mm.
  void Tips(double t, Vec3* tips) const;
  /// Back-of-hand pose at time t (room mm).
  Pose HandPose(double t) const;
  /// The datagram of frame number `frame` at time t (s from the start).
  std::string Datagram(double t, uint32_t frame) const;
};

}  // namespace gs::tracking
