#include "view/live_view.h"

#include <httplib.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/world.h"

namespace gs::view {

// the page's files, embedded at build time (web_assets.cpp, made by embed.cmake)
struct WebAsset {
  const char* path;
  const char* mime;
  const unsigned char* data;
  size_t size;
};
extern const WebAsset kWebAssets[];
extern const size_t kWebAssetCount;

namespace {

constexpr size_t kMaxPointsPerBody = 6000;  // the page's splats per body (every k-th surface point)

void Num(std::string* o, double v, const char* fmt = "%.6g") {
  char b[32];
  std::snprintf(b, sizeof b, fmt, std::isfinite(v) ? v : 0.0);
  *o += b;
}

void Vec(std::string* o, const Vec3& v, const char* fmt = "%.6g") {
  *o += '[';
  Num(o, v.x(), fmt);
  *o += ',';
  Num(o, v.y(), fmt);
  *o += ',';
  Num(o, v.z(), fmt);
  *o += ']';
}

void Str(std::string* o, const std::string& s) {
  *o += '"';
  for (char c : s) {
    if (c == '"' || c == '\\') *o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    *o += c;
  }
  *o += '"';
}

// the renderer's rule (render/renderer.cpp): the force drawn is the one on the grasped object
bool IsObject(const SnapshotRig& rig, int i) {
  if (i < 0 || i >= static_cast<int>(rig.bodies.size())) return false;
  const SurfaceRig& r = rig.bodies[i];
  return !r.fixed && !r.is_plane && r.finger < 0;
}

}  // namespace

bool ParseViewAddress(const std::string& text, std::string* host, int* port, std::string* error) {
  const size_t colon = text.rfind(':');
  const std::string p = colon == std::string::npos ? text : text.substr(colon + 1);
  *host = colon == std::string::npos ? "0.0.0.0" : text.substr(0, colon);
  bool ok = !p.empty() && p.size() <= 5 && std::all_of(p.begin(), p.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (ok) *port = std::stoi(p);
  if (!ok || *port > 65535 || host->empty()) {
    *error = "--view '" + text + "': expected [ADDRESS:]PORT, like 8080 or 127.0.0.1:8080 (port 0: any free port)";
    return false;
  }
  return true;
}

LiveView::LiveView() = default;

LiveView::~LiveView() { Stop(true); }

std::string LiveView::url() const {
  return "http://" + (host_ == "0.0.0.0" ? std::string("localhost") : host_) + ":" + std::to_string(port_) + "/";
}

bool LiveView::Start(const std::string& address, const app::BuiltScene& scene, std::string* error, int avoid_cpu) {
  int port = 0;
  if (!ParseViewAddress(address, &host_, &port, error)) return false;
  const World& w = scene.world;
  {
    auto rig = std::make_shared<SnapshotRig>(*BuildSnapshotRig(w));
    if (scene.has_tracker)  // tracked fingertips are fingertips, as in FrameRecorder
      for (const tracking::FingertipMap& f : scene.tracker.fingertips)
        if (f.body_index >= 0 && f.body_index < static_cast<int>(rig->bodies.size()))
          rig->bodies[f.body_index].finger = std::max(f.finger, 0);  // a tracked hand's palm (-1) too
    rig_ = rig;
  }
  tracked_ = scene.tracked_body;
  force_scale_ = app::DefaultForceScale(w, true);
  WorldSnapshot first;
  TakeSnapshot(w, &first);
  const render::Camera cam = app::SceneOrDefaultCamera(scene, *rig_, first);

  // scene.json: the camera (the off-screen renderer's), and per body its rest points and normals
  std::string& o = scene_json_;
  o = "{\"scene\":";
  Str(&o, scene.name);
  o += ",\"dt_s\":";
  Num(&o, w.params.dt);
  o += ",\"force_scale_m_per_N\":";
  Num(&o, force_scale_);
  o += ",\"tracked_body\":" + std::to_string(tracked_);
  o += ",\"camera\":{\"position\":";
  Vec(&o, cam.position);
  o += ",\"target\":";
  Vec(&o, cam.target);
  o += ",\"up\":";
  Vec(&o, cam.up);
  o += ",\"fov_deg\":";
  Num(&o, cam.fov_deg);
  o += "},\"bodies\":[";
  kept_.assign(rig_->bodies.size(), {});
  fingertip_.assign(rig_->bodies.size(), false);
  for (size_t b = 0; b < rig_->bodies.size(); ++b) {
    const SurfaceRig& r = rig_->bodies[b];
    fingertip_[b] = r.finger >= 0;
    const char* kind = r.is_plane ? "plane" : r.finger >= 0 ? "fingertip" : IsObject(*rig_, static_cast<int>(b)) ? "object" : "fixed";
    const size_t n = r.is_plane ? 0 : r.rest_p.size();
    const size_t stride = std::max<size_t>(1, (n + kMaxPointsPerBody - 1) / kMaxPointsPerBody);
    for (size_t i = 0; i < n; i += stride) kept_[b].push_back(static_cast<int>(i));
    o += b ? ",{" : "{";
    o += "\"name\":";
    Str(&o, r.name);
    o += ",\"kind\":\"";
    o += kind;
    o += "\",\"deformable\":";
    o += r.deformable ? "true" : "false";
    o += ",\"splat_m\":";
    Num(&o, 2.3 * r.spacing * std::sqrt(static_cast<double>(stride)));
    o += ",\"points_mm\":[";
    for (size_t k = 0; k < kept_[b].size(); ++k) {
      const Vec3 p = 1e3 * r.rest_p[kept_[b][k]];
      if (k) o += ',';
      Num(&o, p.x(), "%.4g");
      o += ',';
      Num(&o, p.y(), "%.4g");
      o += ',';
      Num(&o, p.z(), "%.4g");
    }
    o += "],\"normals\":[";
    for (size_t k = 0; k < kept_[b].size(); ++k) {
      const Vec3& p = r.rest_n[kept_[b][k]];
      if (k) o += ',';
      Num(&o, p.x(), "%.3f");
      o += ',';
      Num(&o, p.y(), "%.3f");
      o += ',';
      Num(&o, p.z(), "%.3f");
    }
    o += "]}";
  }
  o += "]}";
  latest_ = std::make_shared<const std::string>(Encode(first, 0));

  server_ = std::make_unique<httplib::Server>();
  httplib::Server& srv = *server_;
  srv.new_task_queue = [] { return new httplib::ThreadPool(6); };
  srv.set_read_timeout(5, 0);
  srv.set_write_timeout(5, 0);
  srv.set_keep_alive_timeout(5);
  for (size_t i = 0; i < kWebAssetCount; ++i) {
    const WebAsset a = kWebAssets[i];
    auto handler = [this, a](const httplib::Request&, httplib::Response& res) {
      requests_.fetch_add(1, std::memory_order_relaxed);
      res.set_content(reinterpret_cast<const char*>(a.data), a.size, a.mime);
      res.set_header("Cache-Control", "no-cache");
    };
    srv.Get(a.path, handler);
    if (std::string(a.path) == "/index.html") srv.Get("/", handler);
  }
  srv.Get("/scene.json", [this](const httplib::Request&, httplib::Response& res) {
    requests_.fetch_add(1, std::memory_order_relaxed);
    res.set_content(scene_json_, "application/json");
  });
  srv.Get("/state.json", [this](const httplib::Request& req, httplib::Response& res) {
    requests_.fetch_add(1, std::memory_order_relaxed);
    int64_t after = -1;
    if (req.has_param("after")) after = std::atoll(req.get_param_value("after").c_str());
    std::shared_ptr<const std::string> frame;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait_for(lock, std::chrono::seconds(1), [&] { return stopping_ || latest_frame_ > after; });
      frame = latest_;
    }
    // the response owns a reference: a slow client keeps its frame alive, nothing else
    res.set_content_provider(frame->size(), "application/json",
                             [frame](size_t offset, size_t length, httplib::DataSink& sink) {
                               return sink.write(frame->data() + offset, std::min(length, frame->size() - offset));
                             });
    res.set_header("Cache-Control", "no-store");
  });
  if (port == 0) {
    port_ = srv.bind_to_any_port(host_.c_str());
    if (port_ <= 0) {
      *error = "--view " + address + ": cannot listen on " + host_;
      return false;
    }
  } else {
    if (!srv.bind_to_port(host_.c_str(), port)) {
      *error = "--view " + address + ": cannot listen on " + host_ + ":" + std::to_string(port) +
               " (in use, or not an address of this machine)";
      return false;
    }
    port_ = port;
  }
  thread_ = std::thread([this, avoid_cpu] {
    // the server's threads (made by listen, inheriting this) come after the simulation and off its core
    setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
    const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    if (avoid_cpu >= 0 && cpus > 1 && avoid_cpu < cpus && cpus <= CPU_SETSIZE) {
      cpu_set_t set;
      CPU_ZERO(&set);
      for (int c = 0; c < static_cast<int>(cpus); ++c)
        if (c != avoid_cpu) CPU_SET(c, &set);
      sched_setaffinity(0, sizeof set, &set);
    }
    server_->listen_after_bind();
  });
  std::printf("view: serving http://%s:%d/ (the page polls up to 30 frames a second)\n", host_.c_str(), port_);
  std::fflush(stdout);
  return true;
}

void LiveView::Stop(bool quiet) {
  if (!server_) return;
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  server_->stop();
  if (thread_.joinable()) thread_.join();
  server_.reset();
  if (!quiet)
    std::printf("view: %lld frames published, %lld requests served\n", static_cast<long long>(frames()),
                static_cast<long long>(requests()));
}

void LiveView::Read(const WorldSnapshot& s) {
  const int64_t n = frames_.load(std::memory_order_relaxed) + 1;
  auto frame = std::make_shared<const std::string>(Encode(s, n));
  {
    std::lock_guard<std::mutex> lock(mu_);
    latest_ = std::move(frame);
    latest_frame_ = n;
  }
  frames_.store(n, std::memory_order_relaxed);
  cv_.notify_all();
}

std::string LiveView::Encode(const WorldSnapshot& s, int64_t frame) {
  std::string& o = buf_;
  o.clear();
  const HudState& h = s.hud;
  o += "{\"frame\":" + std::to_string(frame) + ",\"step\":" + std::to_string(h.step) + ",\"t\":";
  Num(&o, h.time, "%.4f");
  o += ",\"step_ms\":";
  Num(&o, h.step_ms, "%.4f");
  o += ",\"contacts\":" + std::to_string(h.contacts) + ",\"iterations\":" + std::to_string(h.iterations) +
       ",\"residual\":";
  Num(&o, h.residual, "%.3g");
  o += ",\"converged\":";
  o += h.converged ? "true" : "false";
  o += ",\"tracker\":";
  Str(&o, h.tracker);
  // per body: pose, and for a deformed body the sent points' displacements (eq. 8, rest frame, µm)
  o += ",\"bodies\":[";
  for (size_t b = 0; b < s.bodies.size() && b < rig_->bodies.size(); ++b) {
    const BodyState& bs = s.bodies[b];
    const SurfaceRig& r = rig_->bodies[b];
    const Eigen::Quaterniond q(bs.pose.R);
    o += b ? ",{\"p\":" : "{\"p\":";
    Vec(&o, bs.pose.t, "%.7g");
    o += ",\"q\":[";
    Num(&o, q.w(), "%.7g");
    o += ',';
    Num(&o, q.x(), "%.7g");
    o += ',';
    Num(&o, q.y(), "%.7g");
    o += ',';
    Num(&o, q.z(), "%.7g");
    o += ']';
    if (r.deformable && bs.moved && !bs.u.empty()) {
      o += ",\"u_um\":[";
      bool comma = false;
      for (int i : kept_[b]) {
        Vec3 u = Vec3::Zero();
        for (int k = 0; k < SurfaceRig::kWeights; ++k) {
          const size_t j = static_cast<size_t>(i) * SurfaceRig::kWeights + k;
          if (j < r.w.size() && r.w[j] != 0.0 && r.idx[j] >= 0 && r.idx[j] < static_cast<int>(bs.u.size()))
            u += r.w[j] * bs.u[r.idx[j]];
        }
        for (int c = 0; c < 3; ++c) {
          if (comma) o += ',';
          comma = true;
          o += std::to_string(std::lround(1e6 * (std::isfinite(u[c]) ? u[c] : 0.0)));
        }
      }
      o += ']';
    }
    o += '}';
  }
  o += "],\"fingers\":[";
  for (size_t f = 0; f < s.fingers.size(); ++f) {
    o += f ? ",[" : "[";
    for (size_t k = 0; k < s.fingers[f].points.size(); ++k) {
      if (k) o += ',';
      Vec(&o, s.fingers[f].points[k]);
    }
    o += ']';
  }
  // one arrow per touching body pair, as the renderer draws them (--arrows pair): the summed force
  // on the object, its head at the force-weighted centre of the pair's contacts
  struct Pair {
    int a, b;
    Vec3 force = Vec3::Zero(), centroid = Vec3::Zero();
    double weight = 0, slip = 0;
  };
  std::vector<Pair> pairs;
  double grip = 0;
  for (const ContactState& c : s.contacts) {
    const double m = c.force.norm();
    if (!std::isfinite(m)) continue;
    const bool tip_on_object = (c.body[0] == tracked_ && c.body[1] >= 0 && fingertip_[c.body[1]]) ||
                               (c.body[1] == tracked_ && c.body[0] >= 0 && fingertip_[c.body[0]]);
    if (tip_on_object) grip += std::abs(c.force.dot(c.normal));
    Pair* p = nullptr;
    for (Pair& q : pairs)
      if (q.a == c.body[0] && q.b == c.body[1]) p = &q;
    if (!p) {
      pairs.push_back(Pair{c.body[0], c.body[1]});
      p = &pairs.back();
    }
    p->force += c.force;
    p->centroid += m * c.point;
    p->weight += m;
    p->slip += c.slip ? m : 0.0;
  }
  o += "],\"arrows\":[";
  bool first = true;
  for (const Pair& p : pairs) {
    const double sign = !IsObject(*rig_, p.a) && IsObject(*rig_, p.b) ? -1.0 : 1.0;
    const Vec3 d = sign * force_scale_ * p.force;
    if (!(p.weight > 0) || !(d.norm() > 1e-7) || !d.allFinite()) continue;
    o += first ? "{\"tail\":" : ",{\"tail\":";
    first = false;
    Vec(&o, p.centroid / p.weight - d);
    o += ",\"d\":";
    Vec(&o, d);
    o += ",\"force_N\":";
    Num(&o, p.force.norm(), "%.4g");
    o += ",\"slip\":";
    o += p.slip > 0.5 * p.weight ? "true" : "false";
    o += '}';
  }
  o += "],\"grip_N\":";
  Num(&o, grip, "%.4g");
  o += ",\"height_m\":";
  Num(&o, tracked_ >= 0 && tracked_ < static_cast<int>(s.bodies.size()) ? s.bodies[tracked_].pose.t.z() : 0.0, "%.6g");
  o += '}';
  return o;
}

}  // namespace gs::view
