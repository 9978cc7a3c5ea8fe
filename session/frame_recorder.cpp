// The render options and the render thread (the scene's camera section is read in scene_camera.cpp).
#include <algorithm>
#include "session/frame_recorder.h"

#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "render/frame_sink.h"

namespace gs::app {

bool ParseSize(const std::string& text, int* width, int* height, std::string* error) {
  const size_t x = text.find_first_of("xX");
  auto number = [](const std::string& s, int* out) {
    if (s.empty() || s.size() > 5) return false;
    for (char c : s)
      if (c < '0' || c > '9') return false;
    *out = std::stoi(s);
    return true;
  };
  if (x == std::string::npos || !number(text.substr(0, x), width) || !number(text.substr(x + 1), height)) {
    *error = "--size '" + text + "': expected WIDTHxHEIGHT in pixels, like 640x480";
    return false;
  }
  if (*width < 16 || *height < 16 || *width > 8192 || *height > 8192) {
    *error = "--size '" + text + "': each side must be 16 to 8192 pixels";
    return false;
  }
  return true;
}

bool CheckOutputFolder(const std::string& option, const std::string& dir, std::string* error) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir, ec)) {
    *error = option + " " + dir + ": cannot create the folder" + (ec ? ": " + ec.message() : std::string(": not a folder"));
    return false;
  }
  if (access(dir.c_str(), W_OK) != 0) {
    *error = option + " " + dir + ": the folder is not writable";
    return false;
  }
  return true;
}

bool CheckRenderOptions(const RenderOptions& opt, std::string* error) {
  if (!opt.draws()) return true;
  int width = 0, height = 0;
  if (!ParseSize(opt.size, &width, &height, error)) return false;
  if (!opt.video.empty()) {
    if (width % 2 || height % 2) {
      *error = "--video: the size " + opt.size + " has an odd side; H.264 (yuv420p) needs even width and height";
      return false;
    }
    const std::string ext = std::filesystem::path(opt.video).extension().string();
    if (ext != ".mp4" && ext != ".mkv" && ext != ".mov") {
      *error = "--video " + opt.video + ": unknown video type '" + (ext.empty() ? std::string("(no extension)") : ext) +
               "'; name the file .mp4 (or .mkv, .mov)";
      return false;
    }
    if (render::FindExecutable("ffmpeg").empty()) {
      *error = "--video: ffmpeg was not found on PATH (install it: apt-get install ffmpeg), or use --frames DIR";
      return false;
    }
    const std::filesystem::path parent = std::filesystem::path(opt.video).parent_path();
    std::error_code ec;
    if (!parent.empty() && !std::filesystem::is_directory(parent, ec)) {
      *error = "--video " + opt.video + ": folder " + parent.string() + " does not exist";
      return false;
    }
    if (access(parent.empty() ? "." : parent.c_str(), W_OK) != 0) {
      *error = "--video " + opt.video + ": folder " + (parent.empty() ? std::string(".") : parent.string()) +
               " is not writable";
      return false;
    }
  }
  return opt.frames.empty() || CheckOutputFolder("--frames", opt.frames, error);
}

render::Camera SceneOrDefaultCamera(const BuiltScene& scene, const SnapshotRig& rig, const WorldSnapshot& s) {
  // the scripted hand's travel: the objects it carries move with it
  std::vector<Vec3> sweep;
  const auto& keys = scene.script.hand_keys();
  for (const auto& k : keys) sweep.push_back(k.second - keys.front().second);
  const SceneCamera& c = scene.camera;
  render::Camera cam = render::DefaultCamera(rig, s, scene.has_camera ? c.fov_deg : 35.0, 1.0, sweep);
  if (!scene.has_camera) return cam;
  const Vec3 offset = cam.position - cam.target;
  if (c.has_target) cam.target = c.target;
  cam.position = c.has_position ? c.position : cam.target + offset;
  cam.up = c.up.normalized();
  if (!cam.Valid()) cam.up = Vec3::UnitY();  // only when the default framing looks straight along up
  return cam;
}

double DefaultForceScale(const World& w, bool per_pair) {
  double mass = 0;
  for (const Body& b : w.bodies)
    if (b.motion == EMotion::Free && b.finger < 0) mass = std::max(mass, b.mass);
  const double weight = mass > 0 ? mass * 9.81 : 1.0;
  return per_pair ? 0.03 / weight : 0.015 / (weight / 8.0);
}

FrameRecorder::~FrameRecorder() {
  if (thread_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
}

void FrameRecorder::TakeInto(const World& w, const char* tracker, WorldSnapshot* s) const {
  TakeSnapshot(w, s);
  if (!wall_times_) s->hud.step_ms = -1.0;
  if (tracker) s->hud.tracker = tracker;  // reuses the string's capacity (reserved in live mode)
}

bool FrameRecorder::Start(const RenderOptions& opt, const BuiltScene& scene, std::string* error, ERecordMode mode,
                          bool wall_times) {
  if (!opt.enabled()) return true;
  opt_ = opt;
  mode_ = mode;
  wall_times_ = wall_times;
  if (!CheckRenderOptions(opt, error)) return false;
  ParseSize(opt.size, &width_, &height_, error);
  const World& w = scene.world;
  {
    // tracked fingertips (free bodies of their own) are drawn and treated as fingertips
    auto rig = std::make_shared<SnapshotRig>(*BuildSnapshotRig(w));
    if (scene.has_tracker)
      for (const tracking::FingertipMap& f : scene.tracker.fingertips)
        if (f.body_index >= 0 && f.body_index < static_cast<int>(rig->bodies.size()))
          rig->bodies[f.body_index].finger = std::max(f.finger, 0);  // a tracked hand's palm (-1) too
    rig_ = rig;
  }
  auto first = std::make_unique<WorldSnapshot>();
  TakeInto(w, nullptr, first.get());
  camera_ = SceneOrDefaultCamera(scene, *rig_, *first);
  style_.per_pair = opt.arrows == "pair";
  style_.arrows = opt.arrows != "none";
  style_.force_scale = opt.force_scale > 0 ? opt.force_scale : DefaultForceScale(w, style_.per_pair);
  style_.hud = !opt.no_hud;
  queue_.clear();
  pool_.clear();
  if (mode_ == ERecordMode::Live) {
    // llvmpipe rasterises on one thread instead of one per core, so that on a
    // 2-core machine rendering leaves a core to the 1 kHz simulation thread (read
    // once, when the first context is made on the render thread; a value the user
    // set wins)
    setenv("LP_NUM_THREADS", "1", 0);
    // every buffer the simulation thread touches gets its capacity now
    constexpr int kPool = 4;
    first->contacts.reserve(static_cast<size_t>(std::max(w.params.max_contacts, 1)));
    first->hud.tracker.reserve(128);
    queue_.reserve(kPool + 1);
    pool_.reserve(kPool + 1);
    for (int i = 0; i < kPool; ++i) {
      auto s = std::make_unique<WorldSnapshot>(*first);
      s->contacts.reserve(static_cast<size_t>(std::max(w.params.max_contacts, 1)));
      s->hud.tracker.reserve(128);
      pool_.push_back(std::move(s));
    }
  }
  queue_.push_back(std::move(first));
  taken_ = 1;
  drawn_ = 0;
  dropped_ = 0;
  done_ = false;
  active_ = true;
  thread_ = std::thread([this] { Loop(); });
  return true;
}

void FrameRecorder::AfterStep(const World& w, const char* tracker) {
  if (!active_) return;
  if (mode_ == ERecordMode::Live) {
    // never wait: a busy lock leaves the frame due for the next step
    if (!FrameDue(w)) return;
    if (!held_) {
      if (!mu_.try_lock()) return;
      if (!pool_.empty()) {
        held_ = std::move(pool_.back());
        pool_.pop_back();
      }
      mu_.unlock();
      if (!held_) {  // every snapshot is waiting to be drawn: drop this frame time
        dropped_.fetch_add(1, std::memory_order_relaxed);
        ++taken_;
        return;
      }
    }
    TakeInto(w, tracker, held_.get());
    if (!mu_.try_lock()) return;  // retaken and queued on a later step
    queue_.push_back(std::move(held_));
    max_queue_ = std::max(max_queue_, queue_.size());
    mu_.unlock();
    cv_.notify_one();
    ++taken_;
    return;
  }
  // frame k at k / fps simulated seconds; half a step of slack against rounding
  while (FrameDue(w)) {
    std::unique_ptr<WorldSnapshot> s;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!pool_.empty()) {
        s = std::move(pool_.back());
        pool_.pop_back();
      }
    }
    if (!s) s = std::make_unique<WorldSnapshot>();
    TakeInto(w, tracker, s.get());
    {
      std::lock_guard<std::mutex> lock(mu_);
      queue_.push_back(std::move(s));
      max_queue_ = std::max(max_queue_, queue_.size());
    }
    cv_.notify_one();
    ++taken_;
  }
}

void FrameRecorder::Loop() {
  using Clock = std::chrono::steady_clock;
  // live: below the simulation thread; llvmpipe's threads, made with the
  // context, inherit the policy
  if (mode_ == ERecordMode::Live) {
    // nice 10: a CPU share of about a tenth of a normal thread's when they
    // compete, so the simulation thread comes first; not SCHED_IDLE, which
    // starves rendering outright on a busy machine (frames of seconds, and a
    // live that waits minutes at exit for its queued frames)
    setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
    // and off the simulation's core when it has one of its own
    const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    if (opt_.avoid_cpu >= 0 && cpus > 1 && opt_.avoid_cpu < cpus && cpus <= CPU_SETSIZE) {
      cpu_set_t set;
      CPU_ZERO(&set);
      for (int c = 0; c < static_cast<int>(cpus); ++c)
        if (c != opt_.avoid_cpu) CPU_SET(c, &set);
      sched_setaffinity(0, sizeof set, &set);  // best effort: a refusal leaves the thread where it was
    }
  }
  render::Renderer renderer;
  std::string err;
  const bool draw = opt_.draws();  // a reader alone needs no GL context
  bool ok = !draw || renderer.Init(width_, height_, &err);
  render::PngSequence png;
  render::FfmpegVideo video;
  if (ok && !opt_.frames.empty()) ok = png.Open(opt_.frames, &err);
  if (ok && !opt_.video.empty()) ok = video.Open(opt_.video, width_, height_, opt_.fps, &err);
  for (;;) {
    std::unique_ptr<WorldSnapshot> s;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [this] { return done_ || !queue_.empty(); });
      if (queue_.empty()) break;
      s = std::move(queue_.front());
      queue_.erase(queue_.begin());
    }
    if (opt_.reader) opt_.reader->Read(*s);
    if (ok && !draw) drawn_.fetch_add(1, std::memory_order_relaxed);
    if (ok && draw) {
      const auto t0 = Clock::now();
      const render::Image& img = renderer.Draw(*rig_, *s, camera_, style_);
      const auto t1 = Clock::now();
      if (!opt_.frames.empty()) ok = png.Write(img, &err);
      if (ok && !opt_.video.empty()) ok = video.Write(img, &err);
      const auto t2 = Clock::now();
      draw_ms_total_ += std::chrono::duration<double, std::milli>(t1 - t0).count();
      write_ms_total_ += std::chrono::duration<double, std::milli>(t2 - t1).count();
      if (ok) drawn_.fetch_add(1, std::memory_order_relaxed);
    }
    std::lock_guard<std::mutex> lock(mu_);
    pool_.push_back(std::move(s));
  }
  std::string close_err;
  if (!video.Close(&close_err) && ok) {
    ok = false;
    err = close_err;
  }
  if (!ok) error_ = err;
}

bool FrameRecorder::Finish(std::string* error, bool quiet) {
  if (!active_) return true;
  {
    std::lock_guard<std::mutex> lock(mu_);
    done_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  active_ = false;
  if (!error_.empty()) {
    *error = error_;
    return false;
  }
  if (quiet || !opt_.draws()) return true;
  const int drawn = frames_drawn();
  std::printf("rendered %d frames at %dx%d, %d fps (%.1f ms drawing, %.1f ms writing per frame; at most %zu queued",
              drawn, width_, height_, opt_.fps, drawn ? draw_ms_total_ / drawn : 0.0,
              drawn ? write_ms_total_ / drawn : 0.0, max_queue_);
  if (mode_ == ERecordMode::Live) std::printf("; %d frame times dropped while the renderer was behind", frames_dropped());
  std::printf(")");
  if (!opt_.frames.empty()) std::printf("; frames in %s", opt_.frames.c_str());
  if (!opt_.video.empty()) std::printf("; video %s", opt_.video.c_str());
  std::printf("\n");
  return true;
}

}  // namespace gs::app
