// libFuzzer target for the DTrack parser: any byte string parses without a
// crash, a sanitizer report or an out-of-bounds read, and what it keeps is sane
// (finite values, orthonormal rotations on tracked objects, at most 5 fingers).
#include <cstdio>
#include <cstdlib>

#include "tracking/dtrack_parser.h"

namespace {

void Check(bool ok, const char* what) {
  if (!ok) {
    std::fprintf(stderr, "dtrack_fuzz: invariant broken: %s\n", what);
    std::abort();
  }
}

bool Rotation(const gs::Mat3& R) {
  return R.allFinite() && std::abs(R.determinant() - 1.0) < 0.1;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static gs::tracking::DTrackParser parser;
  static gs::tracking::DTrackFrame frame;
  const int errors = parser.Parse(reinterpret_cast<const char*>(data), size, &frame);
  Check(errors >= 0, "error count");
  Check(std::isfinite(frame.timestamp), "timestamp");
  for (const auto& b : frame.bodies) {
    Check(b.position.allFinite() && b.rotation.allFinite(), "6d finite");
    if (b.tracked()) Check(Rotation(b.rotation), "6d rotation");
  }
  for (const auto& h : frame.hands) {
    Check(h.num_fingers >= 0 && h.num_fingers <= 5, "finger count");
    if (h.tracked()) Check(Rotation(h.rotation), "hand rotation");
    for (int i = 0; i < h.num_fingers; ++i) Check(h.fingers[i].room_position.allFinite(), "fingertip");
  }
  for (const auto& f : frame.flysticks) {
    Check(f.num_buttons <= 16 && f.num_analogs <= 8, "flystick counts");
    for (int i = 0; i < f.num_analogs; ++i) Check(std::isfinite(f.analogs[i]), "analog");
  }
  for (const auto& h : frame.humans)
    Check(h.first_joint >= 0 && h.first_joint + h.num_joints <= static_cast<int>(frame.human_joints.size()), "joints");
  for (const auto& m : frame.markers) Check(m.position.allFinite(), "marker");
  return 0;
}
