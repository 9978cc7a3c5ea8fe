// Parser of the ART DTrack ASCII UDP output (DTrack1, DTrack2, DTRACK3): every
// line type of the protocol reference (fr, ts, ts2, 6dcal, 6d, 6dcov, 6df, 6df2,
// 6dmt, 6dmt2, 6dmtr, glcal, gl, 6dj, 6di, 3d, st), following its section 7:
//
// - each line is bounded (CR, LF or CRLF; the datagram stops at the first NUL)
//   before its blocks are read, so a truncated line never swallows the next one;
// - every category is reset per datagram and marked present only when its line
//   was read; objects keep their IDs (look them up by ID, not by position) and
//   the calibration counts (6dcal, glcal) are hints only;
// - unknown line types are ignored; extra numbers at the end of a block are
//   ignored (the 6-value position block of 6d and 6df);
// - numbers are C-locale and correctly rounded (std::from_chars), whatever the
//   process locale;
// - a malformed line is dropped with a counted, categorised error and the rest
//   of the datagram is kept: non-finite numbers, counts larger than the blocks
//   supply or beyond the protocol's limits, and a zero or non-orthonormal
//   rotation on a tracked object are rejected; an oversized datagram is refused.
//
// Positions stay in millimetres and angles in degrees, as sent. Parsing reuses
// the frame's buffers: once they have grown, Parse() does not allocate.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "core/types.h"

namespace gs::tracking {

/// The line types, in the order of the protocol reference.
enum class ELine : int {
  Fr, Ts, Ts2, Cal6d, Body6d, Cov6d, Flystick1, Flystick2, Tool1, Tool2, ToolRef, CalGl, Hand, Human, Inertial,
  Marker, Status, Count
};
/// The identifier of a line type as it appears in the stream ("6dmt2").
const char* LineName(ELine line);

/// Categories of rejected input. Each rejected line counts once, in the category
/// of the first problem found.
enum class EParseError : int {
  Oversized,        ///< the datagram is longer than the parser's limit (whole datagram refused)
  Syntax,           ///< missing '[' or ']', a stray character, a missing count
  BadNumber,        ///< a token that is not a C-locale number of the expected kind
  NonFinite,        ///< inf, nan, or a value out of the double range
  BadCount,         ///< a count out of the protocol's limits (nf > 5, nbt > 16, nct > 8, nj > 200, negative)
  MissingBlock,     ///< a count larger than the blocks the line supplies, or a block with too few numbers
  BadValue,         ///< an ID, quality, frame counter or timestamp out of range; a duplicate ID
  ZeroRotation,     ///< an all-zero rotation matrix on a tracked object
  BadRotation,      ///< a rotation matrix on a tracked object that is not orthonormal
  Count
};
const char* ErrorName(EParseError e);

/// Standard body (6d), measurement-tool reference body (6dmtr).
struct Body6d {
  int id = 0;
  double quality = -1.0;  ///< -1: not tracked, else 0..1
  Vec3 position = Vec3::Zero();  ///< mm, room frame
  Mat3 rotation = Mat3::Zero();  ///< body to room
  bool has_euler = false;
  Vec3 euler_deg = Vec3::Zero();  ///< eta, theta, phi when the position block has 6 values
  bool tracked() const { return quality >= 0.0; }
};

/// Pose covariance (6dcov).
struct Covariance6d {
  int id = 0;
  Vec3 reference = Vec3::Zero();  ///< mm
  double upper[21] = {};          ///< upper triangle of the 6x6 covariance, row by row
};

/// Flystick (6df old format, 6df2).
struct Flystick {
  static constexpr int kMaxButtons = 16, kMaxAnalogs = 8;
  int id = 0;
  double quality = -1.0;
  int num_buttons = 0, num_analogs = 0;
  uint32_t buttons = 0;           ///< bit k = button k
  double analogs[kMaxAnalogs] = {};  ///< -1..1; for 6df the hat switch as analogs 0 (x) and 1 (y)
  Vec3 position = Vec3::Zero();
  Mat3 rotation = Mat3::Zero();
  bool tracked() const { return quality >= 0.0; }
};

/// Measurement tool (6dmt old format, 6dmt2).
struct MeasurementTool {
  static constexpr int kMaxButtons = 32;
  int id = 0;
  double quality = -1.0;
  int num_buttons = 0;
  uint32_t buttons = 0;
  double tip_radius = 0.0;             ///< mm (6dmt2)
  Vec3 position = Vec3::Zero();        ///< mm; the tip for 6dmt2
  Mat3 rotation = Mat3::Zero();
  bool has_covariance = false;
  Mat3 tip_covariance = Mat3::Zero();  ///< mm^2 (6dmt2)
  bool tracked() const { return quality >= 0.0; }
};

struct HandFinger {
  Vec3 position = Vec3::Zero();        ///< fingertip, mm, hand frame
  Mat3 rotation = Mat3::Zero();        ///< outer phalanx, hand frame
  Vec3 room_position = Vec3::Zero();   ///< fingertip, mm, room frame (s + R f)
  Mat3 room_rotation = Mat3::Zero();   ///< outer phalanx, room frame (R R_f)
  double tip_radius = 0.0;             ///< mm
  double phalanx_length[3] = {};       ///< outer, middle, inner (mm)
  double phalanx_angle[2] = {};        ///< outer-middle, middle-inner (deg)
};

/// Fingertracking hand (gl). Fingers: thumb, index, middle, ring, little.
struct Hand {
  static constexpr int kMaxFingers = 5;
  int id = 0;
  double quality = -1.0;
  bool right = false;
  int num_fingers = 0;
  Vec3 position = Vec3::Zero();  ///< back of the hand, mm, room frame
  Mat3 rotation = Mat3::Zero();
  HandFinger fingers[kMaxFingers];
  bool tracked() const { return quality >= 0.0; }
};

/// One joint of an ART-Human model (6dj).
struct HumanJoint {
  int id = 0;
  double quality = -1.0;
  Vec3 position = Vec3::Zero();
  Vec3 angles_deg = Vec3::Zero();  ///< deprecated by ART
  Mat3 rotation = Mat3::Zero();
};
struct Human {
  static constexpr int kMaxJoints = 200;
  int id = 0;
  int first_joint = 0, num_joints = 0;  ///< range in DTrackFrame::human_joints
};

/// Hybrid optical-inertial body (6di).
struct InertialBody {
  int id = 0;
  int state = 0;           ///< 0 not tracked, 1 inertial, 2 optical, 3 both
  double drift_deg = 0.0;
  Vec3 position = Vec3::Zero();
  Mat3 rotation = Mat3::Zero();
  bool tracked() const { return state > 0; }
};

/// Single marker (3d); IDs start at 1.
struct Marker {
  int id = 0;
  double quality = -1.0;
  Vec3 position = Vec3::Zero();
};

/// System status (st, DTRACK3).
struct SystemStatus {
  bool has_general = false, has_messages = false;
  int num_cameras = 0, num_bodies = 0, num_markers = 0;
  int camera_errors = 0, camera_warnings = 0, other_errors = 0, other_warnings = 0, info = 0;
  struct Camera {
    int id = 0, reflections = 0, reflections_used = 0, max_intensity = 0;
  };
  std::vector<Camera> cameras;
};

/// Everything one datagram held. Categories that were not in the datagram (or
/// whose line was dropped) are not present and their lists are empty.
struct DTrackFrame {
  uint32_t present = 0;  ///< bit per ELine
  bool Has(ELine l) const { return (present >> static_cast<int>(l)) & 1u; }

  uint32_t frame = 0;           ///< fr
  double timestamp = -1.0;      ///< s since 00:00 UTC: ts, or from ts2 when present
  int64_t ts2_sec = 0, ts2_usec = 0, latency_us = 0;  ///< ts2
  int cal_bodies = 0, cal_hands = 0;                  ///< 6dcal, glcal (hints only)
  int cal_flysticks = 0, cal_tools = 0, cal_tool_refs = 0, cal_humans = 0;

  std::vector<Body6d> bodies;               ///< 6d (tracked only)
  std::vector<Covariance6d> covariances;    ///< 6dcov
  std::vector<Flystick> flysticks;          ///< 6df or 6df2 (every object)
  std::vector<MeasurementTool> tools;       ///< 6dmt or 6dmt2 (every object)
  std::vector<Body6d> tool_refs;            ///< 6dmtr (tracked only)
  std::vector<Hand> hands;                  ///< gl (tracked only)
  std::vector<Human> humans;                ///< 6dj
  std::vector<HumanJoint> human_joints;
  std::vector<InertialBody> inertials;      ///< 6di
  std::vector<Marker> markers;              ///< 3d
  SystemStatus status;                      ///< st

  const Body6d* FindBody(int id) const;
  const Hand* FindHand(int id) const;
  const Flystick* FindFlystick(int id) const;
  const MeasurementTool* FindTool(int id) const;
  const Marker* FindMarker(int id) const;
  const InertialBody* FindInertial(int id) const;
  void Clear();
};

/// Running counts over every datagram parsed.
struct ParseStats {
  uint64_t datagrams = 0;
  uint64_t lines = 0;          ///< non-empty lines seen
  uint64_t lines_parsed = 0;   ///< known lines kept
  uint64_t unknown_lines = 0;  ///< ignored, not an error
  uint64_t duplicate_lines = 0;  ///< a line type seen twice in a datagram: the last good one is kept (not an error)
  uint64_t trailing_data = 0;    ///< text after a line's last expected block: ignored, as the SDK does (not an error)
  uint64_t errors[static_cast<int>(EParseError::Count)] = {};
  uint64_t TotalErrors() const;
};

struct ParseOptions {
  size_t max_datagram_bytes = 65536;  ///< longer datagrams are refused (UDP carries at most 65507)
  double rotation_tolerance = 1e-2;   ///< max |R^T R - I| entry of a tracked object's matrix
};

class DTrackParser {
 public:
  explicit DTrackParser(const ParseOptions& options = {}) : options_(options) {}

  /// Parses one datagram into `out` (cleared first). Returns the number of
  /// errors found in it (0 for a clean datagram); an oversized datagram leaves
  /// `out` empty. Never throws; never reads past data + size.
  int Parse(const char* data, size_t size, DTrackFrame* out);
  int Parse(std::string_view datagram, DTrackFrame* out) { return Parse(datagram.data(), datagram.size(), out); }

  /// Counts a datagram refused before parsing (truncated by the receiver) as oversized.
  void CountOversized(size_t size);

  const ParseStats& stats() const { return stats_; }
  void ResetStats() { stats_ = ParseStats(); }
  /// The last error: "line 3 (6d): object 2: ..." (empty when none yet).
  const char* last_error() const { return last_error_; }
  EParseError last_error_category() const { return last_category_; }

 private:
  ParseOptions options_;
  ParseStats stats_;
  char last_error_[256] = {};
  EParseError last_category_ = EParseError::Syntax;
  DTrackFrame scratch_;  ///< a line is read here and swapped into the output when it is whole
};

/// R from the 9 column-wise values b0..b8 (R = [[b0 b3 b6],[b1 b4 b7],[b2 b5 b8]]).
Mat3 RotationFromColumns(const double* b);
/// R = Rx(eta) Ry(theta) Rz(phi), degrees (the protocol's Euler angles).
Mat3 RotationFromEulerDeg(double eta, double theta, double phi);

}  // namespace gs::tracking
