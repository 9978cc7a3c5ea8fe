// What a scene's `tracker:` section says: where the DTrack datagrams come from,
// how tracked fingers or bodies become fingertip targets in the world, how the
// fingertips follow them, and what live publishes. Documented in docs/tracking.md.
#pragma once

#include <string>
#include <vector>

#include "core/types.h"
#include "core/virtual_coupling.h"

namespace gs::tracking {

enum class ESource { Hand, Bodies };  ///< a gl Fingertracking hand, or one 6d body per fingertip
enum class EUpAxis { Z, Y };          ///< DTrack room calibration: "Normal" (Z up) or "Powerwall" (Y up)
/// What of a gl finger a target follows: its fingertip (the tracker's pose), the back
/// of the hand (the palm), or one phalanx of a whole tracked hand (core/hand.h)
enum class ESegment { Tip, Palm, Outer, Middle, Inner };

/// One tracked fingertip and the free body it drives.
struct FingertipMap {
  std::string name;      ///< thumb, index, ... (reports, LCM)
  std::string body;      ///< the scene body it drives (a free body)
  int body_index = -1;   ///< resolved when the scene is built
  int finger = 0;        ///< gl: finger index (0 thumb, 1 index, 2 middle, 3 ring, 4 little); the palm: -1
  ESegment segment = ESegment::Tip;  ///< gl: the fingertip, the palm or a phalanx (a tracked hand's segments)
  int body_id = 0;       ///< 6d: the body's ID (0-based, as in the stream)
  Pose offset;           ///< body pose in the tracked fingertip's frame (m)
};

struct TrackerConfig {
  // receiving
  int port = 5000;                            ///< UDP port (5000 is DTrack's convention)
  std::string multicast_group;                ///< join this group when set
  std::vector<std::string> allowed_senders;   ///< IPv4 addresses; empty: any sender
  std::string controller;                     ///< when set, the firewall nudge goes to controller:50107
  // mapping
  ESource source = ESource::Hand;
  int hand_id = 0;
  EUpAxis up = EUpAxis::Z;
  double units_m = 0.001;                     ///< DTrack sends millimetres
  Pose calibration;                           ///< world from room (after the up-axis turn and units)
  int hand_side = -1;                         ///< a tracked hand's side: 1 right, 0 left (gl's lr); -1 any
  double min_phalanx_m = 0.005;               ///< a gl finger with a phalanx shorter than this is not valid
  double max_phalanx_m = 0.12;                ///< nor one with a phalanx or a tip radius longer than this
  std::vector<FingertipMap> fingertips;
  // following
  CouplingParams coupling;
  double lost_timeout_s = 0.5;                ///< a lost fingertip holds its last target this long, then releases
  bool interpolate = true;                    ///< move the target to a new sample over the measured sample interval
  double max_interpolation_s = 0.05;          ///< never spread a sample over more than this
  // live
  double publish_rate_hz = 100.0;             ///< LCM poses and contacts
  std::string lcm_url;                        ///< empty: LCM's default (udpm://239.255.76.67:7667?ttl=0)
};

}  // namespace gs::tracking
