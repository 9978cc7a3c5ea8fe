// Rendering from `graspsim run`, `replay` and `live` (docs/render.md): what the
// options --frames DIR, --video FILE.mp4, --size WxH, --fps N, --force-scale,
// --arrows, --no-hud ask for (app/render_cli.cpp adds them), and a FrameRecorder that takes snapshots on the simulation
// thread at fixed simulated times (frame k at k / fps s, so a rerun or a replay
// renders the same frames) and draws and encodes them on a render thread. The
// simulation never waits for the renderer (ERecordMode).
#pragma once

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "scene/scene_file.h"
#include "core/snapshot.h"
#include "render/camera.h"
#include "render/renderer.h"

namespace gs::app {

/// Reads the recorder's snapshots on the render thread besides (or instead of)
/// drawing them: the live view (view/live_view.h). Read gets each snapshot taken,
/// before it is drawn; it must not wait on anything slow (a network client).
class SnapshotReader {
 public:
  virtual ~SnapshotReader() = default;
  virtual void Read(const WorldSnapshot& s) = 0;
};

struct RenderOptions {
  std::string frames;          ///< folder for frame_NNNNNN.png
  std::string video;           ///< MP4 file (ffmpeg)
  std::string size = "640x480";
  int fps = 30;
  double force_scale = 0.0;    ///< arrow length per force (m/N); 0: the default
  std::string arrows = "pair";  ///< pair (resultant per touching body pair), contact, none
  bool no_hud = false;
  bool discard = false;        ///< draw every frame, write nothing (bench realtime's null sink)
  int avoid_cpu = -1;          ///< live: keep the render thread (and llvmpipe's) off this core, the simulation's
  SnapshotReader* reader = nullptr;  ///< --view: also hands every snapshot to this (not owned)
  bool draws() const { return !frames.empty() || !video.empty() || discard; }
  bool enabled() const { return draws() || reader; }
};

/// Everything about the outputs that can be checked before any work: the size
/// (even sides for a video), the video's type, folder and encoder, the frames'
/// folder (created). False with a message naming the option and the value.
bool CheckRenderOptions(const RenderOptions& opt, std::string* error);

/// Creates `dir` if needed and checks that it is a writable folder; the message
/// names `option` and the folder.
bool CheckOutputFolder(const std::string& option, const std::string& dir, std::string* error);

/// "640x480" -> 640, 480; false with a message naming the problem.
bool ParseSize(const std::string& text, int* width, int* height, std::string* error);

/// The scene's camera, its missing parts from the default framing of snapshot s
/// and of the scene's scripted hand motion (so that a lifted object stays in view).
render::Camera SceneOrDefaultCamera(const BuiltScene& scene, const SnapshotRig& rig, const WorldSnapshot& s);

/// Default arrow scale (m/N): the weight of the heaviest free body that is not a
/// fingertip gives a 3 cm arrow (per pair), or spread over 8 contacts a 1.5 cm one (per contact).
double DefaultForceScale(const World& w, bool per_pair);

/// How the recorder meets the simulation.
enum class ERecordMode {
  /// run, replay: every frame time is drawn; snapshots queue up while the
  /// renderer is behind (the simulation never waits for it)
  Headless,
  /// live: a fixed pool of snapshots made before the loop; the simulation
  /// thread never blocks nor allocates: a frame whose time comes while every
  /// snapshot is still queued is dropped (counted), and the render thread runs
  /// at nice 10 with its llvmpipe thread (one: LP_NUM_THREADS=1 unless set)
  Live,
};

class FrameRecorder {
 public:
  FrameRecorder() = default;
  ~FrameRecorder();
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  /// Checks the options, opens the sinks, takes frame 0 and starts the render
  /// thread. Does nothing (and returns true) when no output was asked for.
  /// `wall_times`: false leaves the step's wall time out of the HUD, so that
  /// frames depend on simulated state only (replay).
  bool Start(const RenderOptions& opt, const BuiltScene& scene, std::string* error,
             ERecordMode mode = ERecordMode::Headless, bool wall_times = true);
  /// A frame time has been reached (call before building a tracker text for AfterStep).
  bool FrameDue(const World& w) const {
    return active_ && static_cast<double>(taken_) / opt_.fps <= w.time + 0.5 * w.params.dt;
  }
  /// After each step: snapshots every frame time reached, with `tracker` (may be
  /// null) as the HUD's tracker state. Never blocks on drawing.
  void AfterStep(const World& w, const char* tracker = nullptr);
  /// Waits for the queued frames, closes the outputs, prints a summary line (unless quiet).
  bool Finish(std::string* error, bool quiet = false);
  bool active() const { return active_; }
  int frames_taken() const { return taken_; }
  /// Frames drawn and written (or, with a reader only, read) so far (any thread).
  int frames_drawn() const { return drawn_.load(std::memory_order_relaxed); }
  /// Live: frame times skipped because the renderer was behind (any thread).
  int frames_dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  void Loop();
  void TakeInto(const World& w, const char* tracker, WorldSnapshot* s) const;
  bool active_ = false;
  ERecordMode mode_ = ERecordMode::Headless;
  bool wall_times_ = true;
  RenderOptions opt_;
  int width_ = 0, height_ = 0;
  std::shared_ptr<const SnapshotRig> rig_;
  render::Camera camera_;
  render::Style style_;
  int taken_ = 0;
  std::mutex mu_;
  std::condition_variable cv_;
  // FIFO of snapshots to draw, and drawn ones to reuse (vectors with their
  // capacity reserved in live mode, so that moving pointers never allocates)
  std::vector<std::unique_ptr<WorldSnapshot>> queue_, pool_;
  std::unique_ptr<WorldSnapshot> held_;  ///< live: taken from the pool, not yet queued
  bool done_ = false;
  std::thread thread_;
  std::atomic<int> drawn_{0}, dropped_{0};
  // render thread results (read after join)
  std::string error_;
  double draw_ms_total_ = 0, write_ms_total_ = 0;
  size_t max_queue_ = 0;
};

}  // namespace gs::app
