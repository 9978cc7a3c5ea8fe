// The live view (issue 22, docs/render.md "Live view"): a running `graspsim replay
// --realtime --view` is looked at by Debian's chromium, headless with WebGL on
// SwiftShader, driven over the DevTools protocol on a pipe (--remote-debugging-pipe:
// NUL-separated JSON on fds 3 and 4). The page is told to stop at the first frame it
// draws that meets a condition, and the screenshot is checked against the simulation
// (the same replay stepped in this process to the frame's step): the object, the
// fingertips and a force arrow must be where the camera puts them, in their colours.
// Skipped, with the reason, when chromium is not installed.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/snapshot.h"
#include "render/camera.h"
#include "session/frame_recorder.h"
#include "session/tracked_sim.h"
#include "tracking/session_log.h"

namespace {

const std::string kRoot = GRASPSIM_SOURCE_ROOT;
const std::string kLog = kRoot + "/assets/demo_session.lcmlog";
const std::string kScene = kRoot + "/config/tracked_hand.yaml";
constexpr int kWidth = 640, kHeight = 480;

std::string FindChromium() {
  if (const char* env = std::getenv("GRASPSIM_CHROMIUM")) return env;
  for (const char* name : {"chromium", "chromium-browser"}) {
    const char* path = std::getenv("PATH");
    std::stringstream dirs(path ? path : "/usr/bin");
    std::string dir;
    while (std::getline(dirs, dir, ':'))
      if (access((dir + "/" + name).c_str(), X_OK) == 0) return dir + "/" + name;
  }
  return "";
}

// `graspsim replay ... --view 127.0.0.1:0`, its stdout read up to the "view: serving" line
struct Graspsim {
  pid_t pid = -1;
  FILE* out = nullptr;
  std::string text;  // stdout read so far
  int port = 0;
  bool Start(const std::vector<std::string>& args) {
    int p[2];
    if (pipe(p) != 0) return false;
    pid = fork();
    if (pid == 0) {
      dup2(p[1], 1);
      close(p[0]);
      close(p[1]);
      std::vector<char*> argv;
      static std::string bin = GRASPSIM_BINARY;
      argv.push_back(bin.data());
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execv(bin.c_str(), argv.data());
      _exit(127);
    }
    close(p[1]);
    out = fdopen(p[0], "r");
    char line[4096];
    while (std::fgets(line, sizeof line, out)) {  // until the server is listening (or the process ends)
      text += line;
      const char* s = std::strstr(line, "view: serving http://127.0.0.1:");
      if (s) {
        port = std::atoi(s + std::strlen("view: serving http://127.0.0.1:"));
        return port > 0;
      }
    }
    return false;
  }
  int Wait() {  // reads the rest of stdout, then the exit status
    char line[4096];
    while (out && std::fgets(line, sizeof line, out)) text += line;
    int status = 0;
    if (pid > 0) waitpid(pid, &status, 0);
    pid = -1;
    if (out) std::fclose(out);
    out = nullptr;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  ~Graspsim() {
    if (pid > 0) {
      kill(pid, SIGKILL);
      Wait();
    }
  }
};

// chromium headless over the DevTools pipe
struct Chromium {
  pid_t pid = -1;
  int to = -1, from = -1;
  int next_id = 1;
  std::string session, profile, buffer;
  bool Start() {
    const std::string bin = FindChromium();
    char tmpl[] = "/tmp/graspsim_view_chromium_XXXXXX";
    if (!mkdtemp(tmpl)) return false;
    profile = tmpl;
    int cmd[2], res[2];
    if (pipe(cmd) != 0 || pipe(res) != 0) return false;
    pid = fork();
    if (pid == 0) {
      // chromium reads commands on fd 3 and writes answers on fd 4
      dup2(cmd[0], 3);
      dup2(res[1], 4);
      for (int fd : {cmd[0], cmd[1], res[0], res[1]})
        if (fd > 4) close(fd);
      const int devnull = open("/dev/null", O_WRONLY);
      dup2(devnull, 1);
      dup2(devnull, 2);
      const std::string dir = "--user-data-dir=" + profile;
      execl(bin.c_str(), bin.c_str(), "--headless=new", "--remote-debugging-pipe", "--no-sandbox",
            "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-first-run", "--mute-audio",
            "--window-size=640,480", dir.c_str(), "about:blank", static_cast<char*>(nullptr));
      _exit(127);
    }
    close(cmd[0]);
    close(res[1]);
    to = cmd[1];
    from = res[0];
    const std::string target = Call("Target.createTarget", "{\"url\":\"about:blank\"}", false);
    const std::string id = Field(target, "targetId");
    if (id.empty()) return false;
    session = Field(Call("Target.attachToTarget", "{\"targetId\":\"" + id + "\",\"flatten\":true}", false), "sessionId");
    if (session.empty()) return false;
    Call("Emulation.setDeviceMetricsOverride",
         "{\"width\":" + std::to_string(kWidth) + ",\"height\":" + std::to_string(kHeight) +
             ",\"deviceScaleFactor\":1,\"mobile\":false}");
    return true;
  }
  // sends a command and returns its answer (events in between are skipped)
  std::string Call(const std::string& method, const std::string& params, bool in_session = true) {
    const int id = next_id++;
    std::string msg = "{\"id\":" + std::to_string(id) + ",\"method\":\"" + method + "\",\"params\":" + params;
    if (in_session) msg += ",\"sessionId\":\"" + session + "\"";
    msg += "}";
    msg.push_back('\0');
    if (write(to, msg.data(), msg.size()) != static_cast<ssize_t>(msg.size())) return "";
    const std::string prefix = "{\"id\":" + std::to_string(id) + ",";
    for (;;) {
      const size_t nul = buffer.find('\0');
      if (nul != std::string::npos) {
        std::string m = buffer.substr(0, nul);
        buffer.erase(0, nul + 1);
        if (m.compare(0, prefix.size(), prefix) == 0) return m;
        continue;
      }
      char chunk[65536];
      const ssize_t n = read(from, chunk, sizeof chunk);
      if (n <= 0) return "";
      buffer.append(chunk, static_cast<size_t>(n));
    }
  }
  // the string value of "key" (JSON escapes undone)
  static std::string Field(const std::string& json, const std::string& key) {
    const std::string k = "\"" + key + "\":\"";
    size_t i = json.find(k);
    if (i == std::string::npos) return "";
    std::string v;
    for (i += k.size(); i < json.size() && json[i] != '"'; ++i) {
      if (json[i] == '\\' && i + 1 < json.size()) {
        ++i;
        v.push_back(json[i] == 'n' ? '\n' : json[i]);
      } else {
        v.push_back(json[i]);
      }
    }
    return v;
  }
  // runs `expr` (a promise of a string) in the page and returns the string
  std::string Evaluate(const std::string& expr) {
    std::string quoted = "\"";
    for (char c : expr) {
      if (c == '"' || c == '\\') quoted += '\\';
      quoted += c == '\n' ? ' ' : c;
    }
    quoted += "\"";
    return Field(Call("Runtime.evaluate", "{\"expression\":" + quoted + ",\"awaitPromise\":true,\"returnByValue\":true}"),
                 "value");
  }
  // navigates, then waits for the first drawn frame meeting `condition` (JS, of the frame s); its JSON
  std::string WaitForFrame(int port, const std::string& condition) {
    Call("Page.navigate", "{\"url\":\"http://127.0.0.1:" + std::to_string(port) + "/\"}");
    // the timeout only turns a page that never draws into a failure instead of a hang: a
    // headless chromium on SwiftShader can take tens of seconds to draw its first
    // frame on a machine busy with other builds (30 s was once not enough)
    return Evaluate("(async () => { const t0 = Date.now(); "
                    "while (!window.graspsimView) { if (Date.now() - t0 > 60000) return 'no page'; "
                    "await new Promise(r => setTimeout(r, 20)); } "
                    "const timeout = new Promise(r => setTimeout(() => r(null), 120000)); "
                    "const d = await Promise.race([graspsimView.waitFor(s => " + condition + "), timeout]); "
                    "return d ? JSON.stringify(d) : 'timeout; last frame drawn: ' + JSON.stringify(graspsimView.drawn); })()");
  }
  std::vector<unsigned char> Screenshot(int* w, int* h) {
    const std::string b64 = Field(Call("Page.captureScreenshot", "{\"format\":\"png\"}"), "data");
    std::vector<unsigned char> bytes;
    int val = 0, bits = -8;
    for (char c : b64) {
      const char* tbl = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
      const char* p = std::strchr(tbl, c);
      if (!p || c == '\0') continue;
      val = (val << 6) + static_cast<int>(p - tbl);
      bits += 6;
      if (bits >= 0) {
        bytes.push_back(static_cast<unsigned char>((val >> bits) & 0xFF));
        bits -= 8;
      }
    }
    int channels = 0;
    unsigned char* px = stbi_load_from_memory(bytes.data(), static_cast<int>(bytes.size()), w, h, &channels, 3);
    std::vector<unsigned char> rgb;
    if (px) rgb.assign(px, px + static_cast<size_t>(*w) * *h * 3);
    stbi_image_free(px);
    return rgb;
  }
  void Kill() {  // an abrupt end: the page's requests are cut off
    if (pid > 0) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
      pid = -1;
    }
    if (to >= 0) close(to);
    if (from >= 0) close(from);
    to = from = -1;
  }
  ~Chromium() {
    Kill();
    std::error_code ec;
    if (!profile.empty()) std::filesystem::remove_all(profile, ec);
  }
};

long FieldNumber(const std::string& json, const std::string& key) {
  const size_t i = json.find("\"" + key + "\":");
  return i == std::string::npos ? -1 : std::atol(json.c_str() + i + key.size() + 3);
}

// The demo replay stepped in this process to `step` (as cmd_replay does): its snapshot and camera.
struct SimAt {
  gs::app::TrackedSim sim;
  gs::WorldSnapshot snap;
  gs::render::Camera camera;
  std::shared_ptr<gs::SnapshotRig> rig;
  bool Run(long step) {
    std::string error;
    if (!sim.Load(kScene, &error)) return false;
    gs::tracking::SessionSummary summary;
    gs::tracking::SessionReader reader;
    if (!gs::tracking::ScanSession(kLog, &summary, &error) || !reader.Open(kLog, &error)) return false;
    gs::World& w = sim.world();
    rig = std::make_shared<gs::SnapshotRig>(*gs::BuildSnapshotRig(w));
    for (const auto& f : sim.scene().tracker.fingertips) rig->bodies[f.body_index].finger = f.finger;
    gs::WorldSnapshot first;
    gs::TakeSnapshot(w, &first);
    camera = gs::app::SceneOrDefaultCamera(sim.scene(), *rig, first);
    gs::tracking::RecordedDatagram d;
    gs::tracking::TargetSample sample;
    bool pending = reader.Next(&d);
    while (w.step_count < step) {
      while (pending && 1e-6 * static_cast<double>(d.monotonic_utime - summary.first_monotonic_utime) <= w.time + 1e-12) {
        sim.Ingest(d.data.data(), d.data.size(), false, &sample);
        sample.sequence = static_cast<uint64_t>(d.sequence);
        sim.Push(sample);
        pending = reader.Next(&d);
      }
      sim.Step();
    }
    gs::TakeSnapshot(w, &snap);
    return true;
  }
};

struct Image {
  std::vector<unsigned char> rgb;
  int w = 0, h = 0;
  const unsigned char* At(int x, int y) const { return &rgb[(static_cast<size_t>(y) * w + x) * 3]; }
  // fraction of the pixels within `r` of (cx, cy) that pass `pred`
  template <class P>
  double Fraction(double cx, double cy, double r, P pred) const {
    int n = 0, hit = 0;
    for (int y = static_cast<int>(cy - r); y <= static_cast<int>(cy + r); ++y)
      for (int x = static_cast<int>(cx - r); x <= static_cast<int>(cx + r); ++x) {
        if (x < 0 || y < 0 || x >= w || y >= h || std::hypot(x + 0.5 - cx, y + 0.5 - cy) > r) continue;
        ++n;
        hit += pred(At(x, y));
      }
    return n ? static_cast<double>(hit) / n : 0.0;
  }
};

// the box (0.95, 0.58, 0.18) and the fingertips (0.93, 0.72, 0.60), lit: told apart by blue over red
bool Orange(const unsigned char* p) { return p[0] > 60 && p[0] >= p[1] && p[1] > p[2] && p[2] < 0.35 * p[0]; }
bool Skin(const unsigned char* p) { return p[0] > 60 && p[0] >= p[1] && p[1] >= p[2] && p[2] > 0.5 * p[0]; }
bool Near(const unsigned char* p, const uint8_t* rgb, int tol) {
  return std::abs(p[0] - rgb[0]) <= tol && std::abs(p[1] - rgb[1]) <= tol && std::abs(p[2] - rgb[2]) <= tol;
}
constexpr uint8_t kStick[3] = {20, 190, 60}, kSlip[3] = {235, 40, 30};

// distance along the ray from `o` (unit `dir`) at which it enters body b's rest-point box, or +inf
double EntersBody(const gs::SurfaceRig& r, const gs::Pose& pose, const gs::Vec3& o, const gs::Vec3& dir) {
  gs::Vec3 lo = gs::Vec3::Constant(1e9), hi = gs::Vec3::Constant(-1e9);
  for (const gs::Vec3& p : r.rest_p) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const gs::Vec3 lo_o = pose.ApplyInverse(o), d = pose.RotateInverse(dir);
  double t0 = 0, t1 = 1e9;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (lo_o[k] < lo[k] || lo_o[k] > hi[k]) return 1e9;
      continue;
    }
    double a = (lo[k] - lo_o[k]) / d[k], b = (hi[k] - lo_o[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t0 <= t1 ? t0 : 1e9;
}

class View : public ::testing::Test {
 protected:
  void SetUp() override {
    if (FindChromium().empty())
      // skipped without chromium, the browser the test drives (setup.sh installs it; CI has it)
      GTEST_SKIP() << "chromium is not installed (apt-get install chromium, as scripts/setup.sh does): the live view's "
                      "browser tests are skipped";
  }
};

TEST_F(View, PageDrawsObjectFingertipsAndArrowWhereTheSimulationSays) {
  Chromium browser;
  ASSERT_TRUE(browser.Start()) << "chromium did not start with --remote-debugging-pipe";
  Graspsim replay;  // long enough for a slow browser to see the grasp: Ctrl-C ends it after the check
  ASSERT_TRUE(replay.Start({"replay", kLog, "--realtime", "--quiet", "--duration", "150", "--view", "127.0.0.1:0"}))
      << replay.text;
  // the first frame drawn with a force arrow (a headless chromium on SwiftShader takes seconds to show
  // its first frame on a loaded machine: often after the grasp, with the box on the table)
  const std::string drawn = browser.WaitForFrame(replay.port, "s.arrows.length >= 1");
  ASSERT_EQ(drawn.front(), '{') << drawn;
  std::printf("frame drawn: %.300s\n", drawn.c_str());
  Image img;
  img.rgb = browser.Screenshot(&img.w, &img.h);
  ASSERT_EQ(img.w, kWidth);
  ASSERT_EQ(img.h, kHeight);
  kill(replay.pid, SIGINT);
  EXPECT_EQ(replay.Wait(), 130) << replay.text;
  EXPECT_NE(replay.text.find("view: "), std::string::npos);

  const long step = FieldNumber(drawn, "step");
  ASSERT_GT(step, 0) << drawn;
  SimAt at;
  ASSERT_TRUE(at.Run(step));
  const gs::World& w = at.sim.world();
  const gs::render::Camera& cam = at.camera;
  const int box = at.sim.scene().tracked_body;
  ASSERT_GE(box, 0);
  double x = 0, y = 0;
  // the box: orange around its centre's projection
  ASSERT_TRUE(cam.Project(at.snap.bodies[box].pose.t, kWidth, kHeight, &x, &y));
  const double ppm = cam.PixelsPerMetre((at.snap.bodies[box].pose.t - cam.position).norm(), kHeight);
  EXPECT_GT(img.Fraction(x, y, 0.006 * ppm, Orange), 0.6) << "box centre at " << x << ", " << y;
  // a point of the background (the view's top-right corner, clear of the HUD) is neither
  EXPECT_FALSE(Orange(img.At(kWidth - 3, 40)) || Skin(img.At(kWidth - 3, 40)));

  // each fingertip that the box does not hide: skin coloured around its centre
  int seen = 0;
  const gs::Vec3 right = (cam.target - cam.position).cross(cam.up).normalized();
  const gs::Vec3 up = right.cross(cam.target - cam.position).normalized();
  for (const auto& f : at.sim.scene().tracker.fingertips) {
    const gs::Vec3 c = at.snap.bodies[f.body_index].pose.t;
    double radius = 0;
    for (const gs::Vec3& p : at.rig->bodies[f.body_index].rest_p) radius = std::max(radius, p.norm());
    bool visible = true;
    for (const gs::Vec3& off : {gs::Vec3::Zero().eval(), (0.6 * radius * right).eval(), (-0.6 * radius * right).eval(),
                                (0.6 * radius * up).eval(), (-0.6 * radius * up).eval()}) {
      const gs::Vec3 dir = (c + off - cam.position).normalized();
      visible = visible && EntersBody(at.rig->bodies[box], at.snap.bodies[box].pose, cam.position, dir) >
                               (c + off - cam.position).norm() - 0.3 * radius;
    }
    if (!visible) continue;
    ++seen;
    ASSERT_TRUE(cam.Project(c, kWidth, kHeight, &x, &y));
    const double r_px = radius * cam.PixelsPerMetre((c - cam.position).norm(), kHeight);
    EXPECT_GT(img.Fraction(x, y, 0.6 * r_px, Skin), 0.4) << f.name << " at " << x << ", " << y << " (" << r_px << " px)";
  }
  EXPECT_GE(seen, 1) << "the box hides every fingertip: the camera of the check is not the page's";

  // the largest pair arrow: its colour (stick or slip) along its shaft
  struct Sum {
    int a, b;
    gs::Vec3 f = gs::Vec3::Zero(), c = gs::Vec3::Zero();
    double m = 0, slip = 0;
  };
  std::vector<Sum> pairs;
  for (const gs::ContactState& k : at.snap.contacts) {
    Sum* p = nullptr;
    for (Sum& q : pairs)
      if (q.a == k.body[0] && q.b == k.body[1]) p = &q;
    if (!p) p = &pairs.emplace_back(Sum{k.body[0], k.body[1]});
    const double m = k.force.norm();
    p->f += k.force, p->c += m * k.point, p->m += m, p->slip += k.slip ? m : 0;
  }
  const double scale = gs::app::DefaultForceScale(w, true);
  const Sum* best = nullptr;
  for (const Sum& p : pairs)
    if (p.m > 0 && (!best || p.f.norm() > best->f.norm())) best = &p;
  ASSERT_NE(best, nullptr) << "no contact at step " << step;
  const double sign = best->b == box ? -1.0 : 1.0;
  const gs::Vec3 d = sign * scale * best->f, head = best->c / best->m;
  const uint8_t* colour = best->slip > 0.5 * best->m ? kSlip : kStick;
  int on = 0;
  for (double s : {0.15, 0.3, 0.45, 0.6}) {
    ASSERT_TRUE(cam.Project(head - (1.0 - s) * d, kWidth, kHeight, &x, &y));
    on += img.Fraction(x, y, 2.5, [&](const unsigned char* p) { return Near(p, colour, 50); }) > 0;
  }
  EXPECT_GE(on, 3) << "arrow of " << best->f.norm() << " N from " << (head - d).transpose() << " to "
                   << head.transpose();
}

// A browser killed mid-session (its long poll cut off) leaves the session running: a second
// browser sees newer frames, and the replay ends normally with the state of a replay without view.
TEST_F(View, ReconnectedBrowserSeesTheSessionGoOn) {
  const std::filesystem::path out = std::filesystem::temp_directory_path() / ("graspsim_view_" + std::to_string(getpid()));
  Graspsim replay;
  ASSERT_TRUE(replay.Start({"replay", kLog, "--realtime", "--quiet", "--duration", "150", "--view", "127.0.0.1:0", "--out",
                            out.string()}))
      << replay.text;
  long first = 0;
  {
    Chromium a;
    ASSERT_TRUE(a.Start());
    const std::string d = a.WaitForFrame(replay.port, "true");
    ASSERT_EQ(d.front(), '{') << d;
    first = FieldNumber(d, "frame");
    a.Kill();
  }
  Chromium b;
  ASSERT_TRUE(b.Start());
  const std::string d = b.WaitForFrame(replay.port, "s.frame > " + std::to_string(first + 3));
  ASSERT_EQ(d.front(), '{') << d;
  EXPECT_GT(FieldNumber(d, "frame"), first + 3);
  Image img;
  img.rgb = b.Screenshot(&img.w, &img.h);
  ASSERT_EQ(img.w, kWidth);
  EXPECT_GT(img.Fraction(kWidth / 2.0, kHeight / 2.0, 200, Orange), 0.02) << "no box on the second page";
  kill(replay.pid, SIGINT);
  EXPECT_EQ(replay.Wait(), 130) << replay.text;
  // the replay's state is what it is without a view, up to the step it was stopped at
  std::ifstream summary(out / "summary.json");
  std::stringstream text;
  text << summary.rdbuf();
  const long steps = FieldNumber(text.str(), "steps");
  ASSERT_GT(steps, 0) << text.str();
  // the same number of steps replayed without a view: the same final state, bit for bit
  char duration[32];
  std::snprintf(duration, sizeof duration, "%.3f", 1e-3 * static_cast<double>(steps));
  const std::string cmd = std::string(GRASPSIM_BINARY) + " replay " + kLog + " --json --duration " + duration;
  FILE* f = popen(cmd.c_str(), "r");
  ASSERT_NE(f, nullptr);
  std::string plain;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, f)) plain += buf;
  pclose(f);
  EXPECT_EQ(FieldNumber(plain, "steps"), steps) << plain;
  EXPECT_FALSE(Chromium::Field(text.str(), "state_hash").empty());
  EXPECT_EQ(Chromium::Field(plain, "state_hash"), Chromium::Field(text.str(), "state_hash"));
  std::error_code ec;
  std::filesystem::remove_all(out, ec);
}

}  // namespace
