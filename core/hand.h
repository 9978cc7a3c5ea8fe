// Whole-hand kinematics from ART Fingertracking (the `gl` line): the pose of every
// segment of a tracked hand, the palm and three phalanges per finger, from what
// the tracker sends per finger (the fingertip's position and the outer phalanx's
// orientation, the fingertip radius, the three phalanx lengths and the two angles
// between phalanges). Pure kinematics: no I/O, Eigen only.
//
// Conventions (ART's, dtrack-protocol.md section 5):
// - a phalanx frame has x along the phalanx toward the fingertip and z toward
//   the pad (the palm side: inferred, since with the chain below the positive
//   angles of every example packet curl the finger toward +z); the joints turn about y;
// - the chain runs back from the tip: outer joint = tip - lo x_outer;
//   R_middle = R_outer Ry(a_om), middle joint = outer joint - lm x_middle;
//   R_inner = R_middle Ry(a_mi), root joint = middle joint - li x_inner. A positive
//   angle is a flexion: the finger curls toward its pad;
// - the hand frame (the back of the hand) has x toward the fingers and z out of
//   the palm; fingers are numbered thumb, index, middle, ring, little (0..4), and a
//   three-finger glove sends thumb, index, middle.
// Lengths are in any one unit (the tracker's mm or the world's m), angles in radians.
#pragma once

#include "core/types.h"

namespace gs {

constexpr int kHandMaxFingers = 5;
constexpr int kPhalanges = 3;

/// Phalanges in ART's order: outer (distal), middle, inner (proximal).
enum class EPhalanx : int { Outer = 0, Middle = 1, Inner = 2 };

/// One tracked finger, as a gl finger block gives it (in the frame of the caller's choice).
struct TrackedFinger {
  Pose tip;                      ///< fingertip position; outer phalanx orientation
  double tip_radius = 0.0;
  double length[kPhalanges] = {};  ///< outer, middle, inner
  double angle[2] = {};            ///< outer-middle, middle-inner (rad)
};

/// The joints and phalanx frames of one finger.
struct FingerChain {
  /// tip, outer joint, middle joint, root joint: joint[k] and joint[k + 1] bound phalanx k
  Vec3 joint[kPhalanges + 1];
  Mat3 R[kPhalanges];  ///< outer, middle, inner phalanx frames (x toward the tip)
};

/// The chain back from the tip (the protocol's joint chain).
FingerChain ChainFromTip(const TrackedFinger& f);

/// The inverse: the tracked finger whose root joint and inner phalanx frame are
/// `inner` (origin at the root joint), with these lengths, angles and radius.
TrackedFinger FingerFromRoot(const Pose& inner, const double length[kPhalanges], const double angle[2],
                             double tip_radius);

/// Pose of phalanx k as a capsule body: origin at the middle of its two joints, the
/// body's z axis along the phalanx toward the tip (a capsule's axis is its z).
Pose PhalanxCapsulePose(const FingerChain& c, EPhalanx k);

/// Why a tracked finger cannot be used, or nullptr: a non-finite value, a
/// rotation that is not one, a phalanx length outside [min_length, max_length], a
/// radius outside (0, max_length], an angle beyond +-180 degrees.
const char* FingerProblem(const TrackedFinger& f, double min_length, double max_length);

/// A hand's shape for placing its segments without a tracker (the scene's start
/// pose, the synthetic hand): the palm and each finger's root in the hand frame.
struct HandFingerModel {
  Pose root;                       ///< root joint and inner phalanx frame at zero flexion (hand frame)
  double length[kPhalanges] = {};  ///< outer, middle, inner
  double radius = 0.0;             ///< of every phalanx (the fingertip radius)
};
struct HandModel {
  int fingers = 5;                  ///< 5, or 3 (thumb, index, middle)
  bool right = true;
  Vec3 palm_size = Vec3::Zero();    ///< full edges of the palm box (hand frame)
  Pose palm;                        ///< palm box centre in the hand frame
  HandFingerModel finger[kHandMaxFingers];
};

/// An average adult right (or left, mirrored in y) hand, in metres: the phalanx
/// lengths and fingertip radii of the protocol's example packets, a palm box of
/// 9 x 8.5 x 2.5 cm under the back-of-hand frame.
HandModel AverageAdultHand(int fingers, bool right);

/// Finger f of the model in the hand pose `hand` with the flexions
/// q = (root, middle-inner, outer-middle) (rad): its tracked finger in the same frame as `hand`.
TrackedFinger PoseFinger(const HandModel& m, int f, const Pose& hand, const Vec3& q);

}  // namespace gs
