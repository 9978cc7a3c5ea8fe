// The render options, the scene's camera section and the render thread.
#include "app/render_options.h"

#include <chrono>
#include <cstdio>

#include "render/frame_sink.h"

namespace gs::app {

void AddRenderOptions(CLI::App* cmd, RenderOptions* opt) {
  cmd->add_option("--frames", opt->frames, "write frames as DIR/frame_NNNNNN.png (docs/render.md)");
  cmd->add_option("--video", opt->video, "write an MP4 video through ffmpeg (H.264)");
  cmd->add_option("--size", opt->size, "frame size WxH (even sides for --video)")->capture_default_str();
  cmd->add_option("--fps", opt->fps, "frames per simulated second")->capture_default_str()->check(CLI::Range(1, 240));
  cmd->add_option("--force-scale", opt->force_scale, "force arrow length (m per N; default from the object's weight)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--arrows", opt->arrows, "force arrows: pair (one per touching body pair), contact, none")
      ->capture_default_str()
      ->check(CLI::IsMember({"pair", "contact", "none"}));
  cmd->add_flag("--no-hud", opt->no_hud, "no heads-up display in the frames");
}

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

void ReadCameraSection(const YAML::Node& node, const std::string& file, Scene* s, std::vector<SceneError>* errors) {
  MapReader m(node, file, "camera", errors);
  if (!m.ok()) return;
  s->has_camera = true;
  SceneCamera& c = s->camera;
  c.has_position = m.Vector3("position_m", &c.position, -1e3, 1e3, false);
  c.has_target = m.Vector3("target_m", &c.target, -1e3, 1e3, false);
  const bool has_up = m.Vector3("up", &c.up, -1e3, 1e3, false);
  m.Number("fov_deg", &c.fov_deg, 1.0, 170.0, false);
  if (has_up && !(c.up.norm() > 1e-9)) m.Error(m.Raw("up"), "'up' must not be the zero vector");
  if (c.has_position && c.has_target && (c.position - c.target).norm() < 1e-9)
    m.Error(m.Raw("target_m"), "'target_m' must differ from 'position_m'");
  else if (c.has_position && c.has_target && c.up.norm() > 1e-9 &&
           (c.target - c.position).normalized().cross(c.up.normalized()).norm() < 1e-6)
    m.Error(m.Raw("up"), "'up' must not point along the view direction (from position_m to target_m)");
  m.Finish();
}

render::Camera SceneOrDefaultCamera(bool has_camera, const SceneCamera& c, const SnapshotRig& rig,
                                    const WorldSnapshot& s) {
  render::Camera cam = render::DefaultCamera(rig, s, has_camera ? c.fov_deg : 35.0);
  if (!has_camera) return cam;
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

bool FrameRecorder::Start(const RenderOptions& opt, const BuiltScene& scene, std::string* error) {
  if (!opt.enabled()) return true;
  opt_ = opt;
  if (!ParseSize(opt.size, &width_, &height_, error)) return false;
  if (!opt.video.empty() && (width_ % 2 || height_ % 2)) {
    *error = "--video: the size " + opt.size + " has an odd side; H.264 (yuv420p) needs even width and height";
    return false;
  }
  if (!opt.video.empty() && render::FindExecutable("ffmpeg").empty()) {
    *error = "--video: ffmpeg was not found on PATH (install it: apt-get install ffmpeg), or use --frames DIR";
    return false;
  }
  const World& w = scene.world;
  rig_ = BuildSnapshotRig(w);
  auto first = std::make_unique<WorldSnapshot>();
  TakeSnapshot(w, first.get());
  camera_ = SceneOrDefaultCamera(scene.has_camera, scene.camera, *rig_, *first);
  style_.per_pair = opt.arrows == "pair";
  style_.arrows = opt.arrows != "none";
  style_.force_scale = opt.force_scale > 0 ? opt.force_scale : DefaultForceScale(w, style_.per_pair);
  style_.hud = !opt.no_hud;
  queue_.push_back(std::move(first));
  taken_ = 1;
  done_ = false;
  active_ = true;
  // the sinks are opened on the render thread; open errors surface in Finish, so
  // check the cheap ones here
  if (!opt.frames.empty()) {
    render::PngSequence probe;
    if (!probe.Open(opt.frames, error)) {
      active_ = false;
      return false;
    }
  }
  thread_ = std::thread([this] { Loop(); });
  return true;
}

void FrameRecorder::AfterStep(const World& w) {
  if (!active_) return;
  // frame k at k / fps simulated seconds; half a step of slack against rounding
  while (static_cast<double>(taken_) / opt_.fps <= w.time + 0.5 * w.params.dt) {
    std::unique_ptr<WorldSnapshot> s;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!pool_.empty()) {
        s = std::move(pool_.front());
        pool_.pop_front();
      }
    }
    if (!s) s = std::make_unique<WorldSnapshot>();
    TakeSnapshot(w, s.get());
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
  render::Renderer renderer;
  std::string err;
  bool ok = renderer.Init(width_, height_, &err);
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
      queue_.pop_front();
    }
    if (ok) {
      const auto t0 = Clock::now();
      const render::Image& img = renderer.Draw(*rig_, *s, camera_, style_);
      const auto t1 = Clock::now();
      if (!opt_.frames.empty()) ok = png.Write(img, &err);
      if (ok && !opt_.video.empty()) ok = video.Write(img, &err);
      const auto t2 = Clock::now();
      draw_ms_total_ += std::chrono::duration<double, std::milli>(t1 - t0).count();
      write_ms_total_ += std::chrono::duration<double, std::milli>(t2 - t1).count();
      if (ok) ++drawn_;
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

bool FrameRecorder::Finish(std::string* error) {
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
  std::printf("rendered %d frames at %dx%d, %d fps (%.1f ms drawing, %.1f ms writing per frame; at most %zu queued)",
              drawn_, width_, height_, opt_.fps, drawn_ ? draw_ms_total_ / drawn_ : 0.0,
              drawn_ ? write_ms_total_ / drawn_ : 0.0, max_queue_);
  if (!opt_.frames.empty()) std::printf("; frames in %s", opt_.frames.c_str());
  if (!opt_.video.empty()) std::printf("; video %s", opt_.video.c_str());
  std::printf("\n");
  return true;
}

}  // namespace gs::app
