// Rendering from `graspsim run` (docs/render.md): the options --frames DIR,
// --video FILE.mp4, --size WxH, --fps N, --force-scale, and a FrameRecorder that
// takes snapshots on the simulation thread at fixed simulated times (frame k at
// k / fps s, so a rerun renders the same frames) and draws and encodes them on a
// render thread. The simulation never waits for the renderer: snapshots queue up
// (reused from a pool once the renderer keeps up).
#pragma once

#include <CLI/CLI.hpp>

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "app/scene_file.h"
#include "core/snapshot.h"
#include "render/camera.h"
#include "render/renderer.h"

namespace gs::app {

struct RenderOptions {
  std::string frames;          ///< folder for frame_NNNNNN.png
  std::string video;           ///< MP4 file (ffmpeg)
  std::string size = "640x480";
  int fps = 30;
  double force_scale = 0.0;    ///< arrow length per force (m/N); 0: the default
  std::string arrows = "pair";  ///< pair (resultant per touching body pair), contact, none
  bool no_hud = false;
  bool enabled() const { return !frames.empty() || !video.empty(); }
};

/// Adds the options to a subcommand.
void AddRenderOptions(CLI::App* cmd, RenderOptions* opt);

/// "640x480" -> 640, 480; false with a message naming the problem.
bool ParseSize(const std::string& text, int* width, int* height, std::string* error);

/// The scene's camera, its missing parts from the default framing of snapshot s.
render::Camera SceneOrDefaultCamera(bool has_camera, const SceneCamera& c, const SnapshotRig& rig,
                                    const WorldSnapshot& s);

/// Default arrow scale (m/N): the weight of the heaviest free body that is not a
/// fingertip gives a 3 cm arrow (per pair), or spread over 8 contacts a 1.5 cm one (per contact).
double DefaultForceScale(const World& w, bool per_pair);

class FrameRecorder {
 public:
  FrameRecorder() = default;
  ~FrameRecorder();
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  /// Checks the options, opens the sinks, takes frame 0 and starts the render
  /// thread. Does nothing (and returns true) when no output was asked for.
  bool Start(const RenderOptions& opt, const BuiltScene& scene, std::string* error);
  /// After each step: snapshots every frame time reached. Never blocks on drawing.
  void AfterStep(const World& w);
  /// Waits for the queued frames, closes the outputs, prints a summary line.
  bool Finish(std::string* error);
  bool active() const { return active_; }
  int frames_taken() const { return taken_; }

 private:
  void Loop();
  bool active_ = false;
  RenderOptions opt_;
  int width_ = 0, height_ = 0;
  std::shared_ptr<const SnapshotRig> rig_;
  render::Camera camera_;
  render::Style style_;
  int taken_ = 0;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::unique_ptr<WorldSnapshot>> queue_, pool_;
  bool done_ = false;
  std::thread thread_;
  // render thread results (read after join)
  std::string error_, gl_error_;
  int drawn_ = 0;
  double draw_ms_total_ = 0, write_ms_total_ = 0;
  size_t max_queue_ = 0;
};

}  // namespace gs::app
