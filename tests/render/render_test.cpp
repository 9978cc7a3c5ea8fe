// Rendering checked by what the pictures show: silhouettes where the camera
// projection puts them, a pressed fingertip flatter than an unpressed one,
// arrow pixels at contacts, HUD text, and small goldens with a tolerance.
// GRASPSIM_UPDATE_GOLDEN=1 rewrites the goldens (look at them before committing).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#define STB_IMAGE_IMPLEMENTATION
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

#include "core/snapshot.h"
#include "core/world.h"
#include "render/camera.h"
#include "render/font.h"
#include "render/frame_sink.h"
#include "render/renderer.h"

namespace gs::render {
namespace {

constexpr int kW = 160, kH = 120;

int AddPlane(World& w) {
  Body b;
  b.name = "table";
  b.motion = EMotion::Fixed;
  BuildPlaneGeometry(&b.geometry);
  w.bodies.push_back(std::move(b));
  return static_cast<int>(w.bodies.size()) - 1;
}

int AddShape(World& w, const ShapeDesc& shape, int points, int cps, double mass, const Vec3& at,
             const DeformationParams& def) {
  Body b;
  b.name = "body";
  b.mass = mass;
  b.inertia = SolidInertia(shape, mass);
  b.pose = Pose::Translation(at);
  GeometryOptions opt;
  opt.points = points;
  opt.control_points = cps;
  EXPECT_EQ(BuildShapeGeometry(shape, opt, &b.geometry), EGeometryError::None);
  b.deform.Build(b.geometry.tree.control_points(), b.geometry.area / cps, def, w.params.dt);
  w.bodies.push_back(std::move(b));
  return static_cast<int>(w.bodies.size()) - 1;
}

Renderer& SharedRenderer() {
  static Renderer r;
  static bool ok = [] {
    std::string error;
    const bool good = r.Init(kW, kH, &error);
    EXPECT_TRUE(good) << error;
    return good;
  }();
  EXPECT_TRUE(ok);
  return r;
}

Style Plain() {
  Style s;
  s.hud = false;
  s.legend = false;
  s.arrows = false;
  return s;
}

// the object's pixels: anything far from the background colour (the tests that
// use masks draw no table)
bool IsObject(const uint8_t* p) {
  return std::abs(p[0] - 235) + std::abs(p[1] - 240) + std::abs(p[2] - 247) > 40;
}

struct Mask {
  int count = 0;
  double cx = 0, cy = 0;
  int top = 1 << 30, bottom = -1;
  std::vector<int> row_width;
};

Mask ObjectMask(const Image& img) {
  Mask m;
  m.row_width.assign(img.height, 0);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (IsObject(img.At(x, y))) {
        ++m.count;
        m.cx += x + 0.5;
        m.cy += y + 0.5;
        m.top = std::min(m.top, y);
        m.bottom = std::max(m.bottom, y);
        ++m.row_width[y];
      }
  if (m.count) m.cx /= m.count, m.cy /= m.count;
  return m;
}

// a soft ball pressed on a table by its weight: real contacts and deformation
struct PressedBall {
  World w;
  int ball = -1;
  std::shared_ptr<const SnapshotRig> rig;
  WorldSnapshot snap;
  PressedBall() {
    w.params.dt = 1e-3;
    w.params.solver.tolerance = 1e-6;
    w.params.solver.max_iterations = 200;
    // what is drawn is checked here, not the solver: Gauss-Seidel alone presses the
    // ball in to within 1 um of the Newton-continued step, at a fifth of the cost
    w.params.newton_max_steps = 0;
    AddPlane(w);
    ShapeDesc s;
    s.type = EShape::Sphere;
    s.radius = 0.01;
    DeformationParams def;
    def.model = EDeformation::Gaussian;
    def.stiffness = 60;
    def.damping = 0.5;
    def.influence_radius = 0.003;
    ball = AddShape(w, s, 3000, 400, 0.3, Vec3(0, 0, 0.0102), def);
    w.bodies[ball].linear_damping = 0.5;
    w.bodies[ball].angular_damping = 1e-4;
    w.Finalize();
    for (int i = 0; i < 250; ++i) w.Step();
    rig = BuildSnapshotRig(w);
    TakeSnapshot(w, &snap);
    // the same without the table, for silhouettes
    auto bare = std::make_shared<SnapshotRig>(*rig);
    bare->bodies[0].is_plane = false;
    no_table = bare;
  }
  std::shared_ptr<const SnapshotRig> no_table;
  Camera SideCamera() const {
    Camera c;
    const Vec3 centre = w.bodies[ball].pose.t;
    c.target = Vec3(centre.x(), centre.y(), 0.008);
    c.position = c.target + Vec3(0, -0.07, 0.004);
    c.fov_deg = 30;
    return c;
  }
};

const PressedBall& Pressed() {
  static PressedBall p;
  return p;
}

std::string Golden(const std::string& name) { return std::string(GRASPSIM_TEST_DATA) + "/render/" + name; }

// compares with a tolerance: at most 1% of pixels may differ by more than 48 in a channel
void ExpectMatchesGolden(const Image& img, const std::string& name) {
  const std::string path = Golden(name);
  if (std::getenv("GRASPSIM_UPDATE_GOLDEN")) {
    std::string error;
    ASSERT_TRUE(WritePng(path, img, &error)) << error;
    return;
  }
  int w = 0, h = 0, n = 0;
  unsigned char* data = stbi_load(path.c_str(), &w, &h, &n, 4);
  ASSERT_NE(data, nullptr) << "cannot read golden " << path << " (GRASPSIM_UPDATE_GOLDEN=1 writes it)";
  ASSERT_EQ(w, img.width);
  ASSERT_EQ(h, img.height);
  int bad = 0;
  for (int i = 0; i < w * h; ++i) {
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(data[4 * i + c]) - int(img.rgba[4 * i + c])));
    bad += d > 48;
  }
  stbi_image_free(data);
  EXPECT_LE(bad, w * h / 100) << name << ": " << bad << " pixels differ; if the change is intended, "
                              << "rerun with GRASPSIM_UPDATE_GOLDEN=1 and look at the picture";
}

TEST(Snapshot, UniformDisplacementMovesEveryPointAndKeepsNormals) {
  World w;
  ShapeDesc s;
  s.type = EShape::Box;
  s.half_extents = Vec3(0.01, 0.015, 0.02);
  DeformationParams def;
  def.model = EDeformation::Gaussian;
  def.stiffness = 1000;
  def.influence_radius = 0.003;
  const int b = AddShape(w, s, 2000, 200, 0.1, Vec3(0.1, 0.2, 0.3), def);
  w.Finalize();
  const Vec3 u(0.001, -0.002, 0.0005);
  for (Vec3& v : w.bodies[b].u) v = u;
  auto rig = BuildSnapshotRig(w);
  WorldSnapshot snap;
  TakeSnapshot(w, &snap);
  ASSERT_TRUE(snap.bodies[b].moved);
  std::vector<SurfaceFrame> out;
  ExpandSurfaces(*rig, snap, &out);
  const PointCloud& cloud = w.bodies[b].geometry.cloud;
  ASSERT_EQ(out[b].positions.size(), cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_LT((out[b].positions[i] - (cloud.positions[i] + u + Vec3(0.1, 0.2, 0.3))).norm(), 1e-12);
    EXPECT_LT((out[b].normals[i] - cloud.normals[i]).norm(), 1e-9);
  }
}

TEST(Snapshot, PressedPointsMoveInAndTheirNormalsTurnWithTheSurface) {
  const PressedBall& p = Pressed();
  std::vector<SurfaceFrame> out;
  ExpandSurfaces(*p.rig, p.snap, &out);
  const SurfaceFrame& f = out[p.ball];
  const PointCloud& cloud = p.w.bodies[p.ball].geometry.cloud;
  const Pose& pose = p.snap.bodies[p.ball].pose;
  // the lowest rest point sits below the table; deformed it is pushed up to (about) the table
  double rest_low = 1e9, def_low = 1e9;
  int lowest = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const double z = pose.Apply(cloud.positions[i]).z();
    if (z < rest_low) rest_low = z, lowest = static_cast<int>(i);
    def_low = std::min(def_low, f.positions[i].z());
  }
  EXPECT_LT(rest_low, -5e-4) << "the ball does not press into the table: the test scene is too stiff";
  EXPECT_GT(def_low, rest_low + 4e-4);
  // a flattened bottom faces the table: the normals near the bottom point more downward than at rest
  double rest_dot = 0, def_dot = 0;
  int counted = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Vec3 rest = pose.Apply(cloud.positions[i]);
    const double ring = (rest - pose.Apply(cloud.positions[lowest])).norm();
    if (ring < 0.002 || ring > 0.004) continue;
    rest_dot += -pose.Rotate(cloud.normals[i]).z();
    def_dot += -f.normals[i].z();
    ++counted;
  }
  ASSERT_GT(counted, 10);
  EXPECT_GT(def_dot / counted, rest_dot / counted + 0.02);
}

TEST(Render, ContextIsMesaAndNotANoOp) {
  Renderer& r = SharedRenderer();
  EXPECT_NE(r.gl_version().find("Mesa"), std::string::npos) << r.gl_version();
}

TEST(Render, SphereSilhouetteLandsWhereTheCameraProjectsIt) {
  World w;
  ShapeDesc s;
  s.type = EShape::Sphere;
  s.radius = 0.02;
  const Vec3 centre(0.012, -0.006, 0.03);
  AddShape(w, s, 6000, 300, 0.1, centre, DeformationParams{});
  w.Finalize();
  auto rig = BuildSnapshotRig(w);
  WorldSnapshot snap;
  TakeSnapshot(w, &snap);
  Camera cam;
  cam.position = Vec3(0.2, -0.25, 0.15);
  cam.target = Vec3(0, 0, 0.02);  // off-centre on purpose
  cam.fov_deg = 30;
  const Image& img = SharedRenderer().Draw(*rig, snap, cam, Plain());
  const Mask m = ObjectMask(img);
  double px = 0, py = 0;
  ASSERT_TRUE(cam.Project(centre, kW, kH, &px, &py));
  ASSERT_GT(m.count, 100);
  EXPECT_NEAR(m.cx, px, 1.5);
  EXPECT_NEAR(m.cy, py, 1.5);
  // area: a disc of the projected radius (within 12%, the splats fringe the edge)
  const double depth = (centre - cam.position).dot((cam.target - cam.position).normalized());
  const double r_px = s.radius * cam.PixelsPerMetre(depth, kH);
  EXPECT_NEAR(std::sqrt(m.count / M_PI), r_px, 0.12 * r_px);
  ExpectMatchesGolden(img, "sphere_160x120.png");
}

TEST(Render, DefaultCameraFramesEveryBody) {
  World w;
  ShapeDesc s;
  s.type = EShape::Box;
  s.half_extents = Vec3(0.03, 0.01, 0.01);
  AddShape(w, s, 3000, 200, 0.1, Vec3(0.5, 0.2, 0.1), DeformationParams{});
  w.Finalize();
  auto rig = BuildSnapshotRig(w);
  WorldSnapshot snap;
  TakeSnapshot(w, &snap);
  const Camera cam = DefaultCamera(*rig, snap);
  ASSERT_TRUE(cam.Valid());
  for (const Vec3& p : w.bodies[0].geometry.cloud.positions) {
    double x, y;
    ASSERT_TRUE(cam.Project(p + Vec3(0.5, 0.2, 0.1), kW, kH, &x, &y));
    EXPECT_GT(x, 0);
    EXPECT_LT(x, kW);
    EXPECT_GT(y, 0);
    EXPECT_LT(y, kH);
  }
}

TEST(Render, PressedFingertipSilhouetteIsFlatterThanUnpressed) {
  const PressedBall& p = Pressed();
  const Camera cam = p.SideCamera();
  Renderer& r = SharedRenderer();
  const Image pressed_img = r.Draw(*p.rig, p.snap, cam, Plain());
  const Mask pressed = ObjectMask(r.Draw(*p.no_table, p.snap, cam, Plain()));
  WorldSnapshot rest = p.snap;
  for (Vec3& u : rest.bodies[p.ball].u) u.setZero();
  rest.bodies[p.ball].moved = false;
  const Mask unpressed = ObjectMask(r.Draw(*p.no_table, rest, cam, Plain()));
  ASSERT_GT(pressed.count, 500);
  ASSERT_GT(unpressed.count, 500);
  // width 2 pixels above the lowest row, over the widest row
  auto flatness = [](const Mask& m) {
    const int widest = *std::max_element(m.row_width.begin(), m.row_width.end());
    return double(m.row_width[m.bottom - 2]) / widest;
  };
  EXPECT_GT(flatness(pressed), flatness(unpressed) + 0.15)
      << "pressed " << flatness(pressed) << " unpressed " << flatness(unpressed);
  EXPECT_LT(pressed.bottom, unpressed.bottom);  // the bottom is pushed up
  ExpectMatchesGolden(pressed_img, "pressed_ball_160x120.png");
}

TEST(Render, ForceArrowsAppearAtContactsInStickAndSlipColours) {
  const PressedBall& p = Pressed();
  ASSERT_GT(p.snap.contacts.size(), 3u);
  Camera cam;
  cam.target = Vec3(0, 0, 0.005);
  cam.position = Vec3(0.05, -0.08, 0.05);
  cam.fov_deg = 30;
  Style st = Plain();
  st.arrows = true;
  st.force_scale = 0.1;  // m/N: the ball's ~0.1 N contacts give 1 cm arrows
  Renderer& r = SharedRenderer();
  auto coloured = [](const Image& img, const uint8_t* rgb, double x, double y, int radius) {
    int n = 0;
    for (int yy = int(y) - radius; yy <= int(y) + radius; ++yy)
      for (int xx = int(x) - radius; xx <= int(x) + radius; ++xx) {
        if (xx < 0 || yy < 0 || xx >= img.width || yy >= img.height) continue;
        const uint8_t* q = img.At(xx, yy);
        n += std::abs(q[0] - rgb[0]) < 8 && std::abs(q[1] - rgb[1]) < 8 && std::abs(q[2] - rgb[2]) < 8;
      }
    return n;
  };
  const Image with = r.Draw(*p.rig, p.snap, cam, st);
  // the arrow of the largest force: its middle is drawn in its colour
  const ContactState* big = &p.snap.contacts[0];
  for (const ContactState& c : p.snap.contacts)
    if (c.force.norm() > big->force.norm()) big = &c;
  // the force on the ball (contact forces are on body[0]), its head at the contact
  const int ball = p.ball;
  const Vec3 on_ball = (big->body[0] == ball ? 1.0 : -1.0) * big->force;
  ASSERT_GT(on_ball.z(), 0.0) << "the table pushes the ball up";
  double x, y;
  ASSERT_TRUE(cam.Project(big->point - 0.5 * st.force_scale * on_ball, kW, kH, &x, &y));
  EXPECT_GT(coloured(with, big->slip ? kSlipRgb : kStickRgb, x, y, 2), 0);
  // no arrows, no arrow pixels
  const Image without = r.Draw(*p.rig, p.snap, cam, Plain());
  EXPECT_EQ(coloured(without, kStickRgb, x, y, 2) + coloured(without, kSlipRgb, x, y, 2), 0);
  // one contact marked slipping turns red
  WorldSnapshot one = p.snap;
  one.contacts = {*big};
  one.contacts[0].slip = true;
  const Image slip = r.Draw(*p.rig, one, cam, st);
  EXPECT_GT(coloured(slip, kSlipRgb, x, y, 2), 0);
  EXPECT_EQ(coloured(slip, kStickRgb, x, y, 2), 0);
}

TEST(Render, HudTextIsDrawnAndFollowsTheNumbers) {
  const PressedBall& p = Pressed();
  Style st = Plain();
  st.hud = true;
  Renderer& r = SharedRenderer();
  auto white_in_hud = [](const Image& img) {
    int n = 0;
    for (int y = 0; y < 50; ++y)
      for (int x = 0; x < img.width; ++x) {
        const uint8_t* q = img.At(x, y);
        n += q[0] == 255 && q[1] == 255 && q[2] == 255;
      }
    return n;
  };
  const Camera cam = p.SideCamera();
  const Image a = r.Draw(*p.rig, p.snap, cam, st);
  EXPECT_GT(white_in_hud(a), 200);
  EXPECT_EQ(white_in_hud(r.Draw(*p.rig, p.snap, cam, Plain())), 0);
  WorldSnapshot later = p.snap;
  later.hud.time += 1.111;
  const Image b = r.Draw(*p.rig, later, cam, st);
  EXPECT_NE(a.rgba, b.rgba);
  std::vector<std::string> lines = HudLines(p.snap.hud);
  ASSERT_EQ(lines.size(), 4u);  // no tracker: no tracker line
  EXPECT_NE(lines[0].find("t = 0.250 s"), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("step time"), std::string::npos) << lines[1];
  HudState h = p.snap.hud;
  h.step_ms = -1;  // replay: no wall times, frames depend on the simulation only
  h.tracker = "3/3 tracking";
  lines = HudLines(h);
  ASSERT_EQ(lines.size(), 4u);
  for (const std::string& l : lines) EXPECT_EQ(l.find("step time"), std::string::npos) << l;
  EXPECT_EQ(lines.back(), "tracker 3/3 tracking");
}

// a ball lifted 3 cm casts a shadow on the table: table pixels darker than
// without the ball, outside the ball's own silhouette, and below it in the picture
TEST(Render, LiftedBallCastsAShadowOnTheTableBelowIt) {
  const PressedBall& p = Pressed();
  WorldSnapshot lifted = p.snap, gone = p.snap;
  lifted.contacts.clear();
  gone.contacts.clear();
  lifted.bodies[p.ball].pose.t.z() += 0.03;
  gone.bodies[p.ball].pose.t.x() += 10.0;  // out of the picture, with its shadow
  Camera cam;
  const Vec3 c = lifted.bodies[p.ball].pose.t;
  cam.target = Vec3(c.x(), c.y(), 0.015);
  cam.position = cam.target + Vec3(0.01, -0.09, 0.06);
  cam.fov_deg = 35;
  Renderer& r = SharedRenderer();
  const Image with = r.Draw(*p.rig, lifted, cam, Plain());
  const Image table = r.Draw(*p.rig, gone, cam, Plain());
  const Image ball = r.Draw(*p.no_table, lifted, cam, Plain());
  const Mask ball_mask = ObjectMask(ball);
  ASSERT_GT(ball_mask.count, 200);
  int n = 0;
  double cy = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      if (IsObject(ball.At(x, y))) continue;
      const uint8_t *a = with.At(x, y), *b = table.At(x, y);
      if (a[0] + a[1] + a[2] + 60 < b[0] + b[1] + b[2]) {
        ++n;
        cy += y + 0.5;
      }
    }
  ASSERT_GT(n, ball_mask.count / 4) << "no shadow under the lifted ball";
  EXPECT_GT(cy / n, ball_mask.cy + 5) << "the shadow is not below the ball";
  std::printf("shadow: %d pixels (ball %d), centre row %.1f (ball %.1f)\n", n, ball_mask.count, cy / n, ball_mask.cy);
}

TEST(Text, GlyphsCoverTheHudCharacters) {
  Image img;
  img.Resize(200, 20);
  DrawText(&img, 0, 0, "0123456789", 1, Rgb{255, 255, 255});
  // every digit has pixels in its own cell
  for (int d = 0; d < 10; ++d) {
    int n = 0;
    for (int y = 0; y < 9; ++y)
      for (int x = d * 6; x < d * 6 + 5; ++x) n += img.At(x, y)[0] == 255;
    EXPECT_GT(n, 5) << d;
  }
  EXPECT_EQ(TextWidth("abc", 2), 36);
}

TEST(FrameSink, OddSizeAndMissingFfmpegGiveClearErrors) {
  FfmpegVideo v;
  std::string error;
  EXPECT_FALSE(v.Open("/tmp/graspsim_render_test_odd.mp4", 161, 120, 30, &error));
  EXPECT_NE(error.find("odd"), std::string::npos) << error;
  setenv("GRASPSIM_FFMPEG", "/nonexistent/ffmpeg", 1);
  FfmpegVideo v2;
  EXPECT_FALSE(v2.Open("/tmp/graspsim_render_test_missing.mp4", 160, 120, 30, &error));
  EXPECT_NE(error.find("ffmpeg was not found"), std::string::npos) << error;
  unsetenv("GRASPSIM_FFMPEG");
}

TEST(FrameSink, PngSequenceAndVideoAreWritten) {
  const std::string dir = ::testing::TempDir() + "/graspsim_render_frames";
  std::filesystem::remove_all(dir);
  PngSequence png;
  std::string error;
  ASSERT_TRUE(png.Open(dir, &error)) << error;
  Image img;
  img.Resize(64, 48);
  for (int i = 0; i < 3; ++i) {
    FillRect(&img, 0, 0, 64, 48, Rgb{uint8_t(80 * i), 100, 200}, 1.0);
    ASSERT_TRUE(png.Write(img, &error)) << error;
  }
  EXPECT_TRUE(std::filesystem::exists(dir + "/frame_000002.png"));
  int w = 0, h = 0, n = 0;
  unsigned char* back = stbi_load((dir + "/frame_000001.png").c_str(), &w, &h, &n, 4);
  ASSERT_NE(back, nullptr);
  EXPECT_EQ(w, 64);
  EXPECT_EQ(back[0], 80);
  stbi_image_free(back);
  // the PNG part ran above; the MP4 part is skipped only where ffmpeg is absent
  if (FindExecutable("ffmpeg").empty()) GTEST_SKIP() << "ffmpeg is not installed";
  const std::string mp4 = dir + "/clip.mp4";
  FfmpegVideo v;
  ASSERT_TRUE(v.Open(mp4, 64, 48, 10, &error)) << error;
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(v.Write(img, &error)) << error;
  ASSERT_TRUE(v.Close(&error)) << error;
  EXPECT_GT(std::filesystem::file_size(mp4), 200u);
}

TEST(FrameSink, AnEncoderThatQuitsIsAnErrorNotASigpipe) {
  // skipped only where ffmpeg is absent (optional; scripts/setup.sh installs it)
  if (FindExecutable("ffmpeg").empty()) GTEST_SKIP() << "ffmpeg is not installed";
  // an output ffmpeg cannot open: it exits at once, our writes then fail
  FfmpegVideo v;
  std::string error;
  const std::string dir = ::testing::TempDir() + "/graspsim_render_quit";
  std::filesystem::create_directories(dir);
  ASSERT_TRUE(v.Open(dir + "/clip.no_such_container_xyz", 64, 48, 10, &error)) << error;
  Image img;
  img.Resize(64, 48);
  bool ok = true;
  for (int i = 0; i < 400 && ok; ++i) ok = v.Write(img, &error);
  const bool closed = v.Close(&error);
  EXPECT_FALSE(ok && closed);
  EXPECT_NE(error.find("ffmpeg"), std::string::npos) << error;
}

}  // namespace
}  // namespace gs::render
