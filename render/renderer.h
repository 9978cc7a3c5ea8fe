// Off-screen drawing of world snapshots through OSMesa (llvmpipe, no GPU, no
// display). A Renderer owns one OSMesa context and its frame: create it, Init
// and Draw on the same thread (a context is current on one thread only).
//
// What a frame shows:
// - every body's surface points, deformed by eq. 8 with recomputed normals,
//   as lit splats sized from the point spacing (planes as a checkerboard);
// - each finger's links as lit cylinders from its base to its fingertip;
// - an arrow per contact force on the grasped object (a body neither fixed nor
//   a fingertip; else on body[0]), its head at the contact point, or per
//   touching body pair (their resultant), length force * force_scale, green
//   while sticking, red on the friction cone's boundary (slipping; for a pair:
//   when most of its force slips), drawn over the surfaces with a dark outline;
//   a legend gives the scale;
// - shadows of the surfaces and finger links on the planes (light from above);
// - a HUD: simulated time, step, step time (unless negative), contacts,
//   iterations, residual, tracker state (unless 'none').
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/snapshot.h"
#include "render/camera.h"
#include "render/image.h"

namespace gs::render {

struct Style {
  double force_scale = 0.01;   ///< arrow length per force (m/N)
  double legend_force = 0.0;   ///< force shown by the legend bar (N); 0: a round value near 3 cm of arrow
  bool hud = true;
  bool arrows = true;
  /// one arrow per touching body pair (their summed force at the force-weighted
  /// centroid of their contacts) instead of one per contact
  bool per_pair = false;
  bool legend = true;
};

/// Colours used, for tests and documentation.
constexpr uint8_t kStickRgb[3] = {20, 190, 60};
constexpr uint8_t kSlipRgb[3] = {235, 40, 30};
constexpr uint8_t kHudTextRgb[3] = {255, 255, 255};

class Renderer {
 public:
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Creates the context and a width x height frame; false with *error set.
  bool Init(int width, int height, std::string* error);
  /// Expands the surfaces (eq. 8) and draws the snapshot. The returned image
  /// stays valid until the next Draw.
  const Image& Draw(const SnapshotRig& rig, const WorldSnapshot& s, const Camera& cam, const Style& style);

  int width() const { return frame_.width; }
  int height() const { return frame_.height; }
  /// Times of the last Draw (ms): surface expansion, GL drawing (up to glFinish), overlays.
  double expand_ms() const { return expand_ms_; }
  double draw_ms() const { return draw_ms_; }
  double overlay_ms() const { return overlay_ms_; }
  /// "4.5 (Compatibility Profile) Mesa ..." once initialised.
  const std::string& gl_version() const { return gl_version_; }

 private:
  struct Context;
  std::unique_ptr<Context> ctx_;
  Image frame_;
  std::vector<SurfaceFrame> surfaces_;
  struct PairSum {
    int a = -1, b = -1;
    Vec3 force = Vec3::Zero(), centroid = Vec3::Zero();
    double weight = 0, slip_weight = 0;
  };
  std::vector<PairSum> pairs_;
  struct ArrowItem {
    Vec3 from, d;
    bool slip = false;
  };
  std::vector<ArrowItem> arrows_;
  double expand_ms_ = 0, draw_ms_ = 0, overlay_ms_ = 0;
  std::string gl_version_;
};

/// The HUD's lines for a snapshot (what Draw writes top left).
std::vector<std::string> HudLines(const HudState& h);

}  // namespace gs::render
