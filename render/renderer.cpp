// OSMesa context, surfaces as splats, finger links, force arrows, legend and HUD.
#define GL_GLEXT_PROTOTYPES
#include "render/renderer.h"

#include <GL/gl.h>
#include <GL/osmesa.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "render/font.h"

namespace gs::render {

struct Renderer::Context {
  OSMesaContext ctx = nullptr;
  ~Context() {
    if (ctx) OSMesaDestroyContext(ctx);
  }
};

namespace {

using Clock = std::chrono::steady_clock;
double Ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

// a round value (1, 2 or 5 times a power of ten) near x
double RoundValue(double x) {
  if (!(x > 0) || !std::isfinite(x)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  const double m = x / p;
  return (m < 1.5 ? 1.0 : m < 3.5 ? 2.0 : m < 7.5 ? 5.0 : 10.0) * p;
}

void BodyColour(const SurfaceRig& r, bool fingertip, float* c) {
  if (fingertip) {
    c[0] = 0.93f, c[1] = 0.72f, c[2] = 0.60f;
  } else if (r.deformable) {
    c[0] = 0.95f, c[1] = 0.58f, c[2] = 0.18f;
  } else {
    c[0] = 0.55f, c[1] = 0.65f, c[2] = 0.80f;
  }
  c[3] = 1.0f;
}

void DrawPlane(const Pose& pose, const Camera& cam) {
  // a checkerboard around the camera target's foot point, in the plane's frame
  const double dist = (cam.position - cam.target).norm();
  const double cell = RoundValue(dist / 8.0);
  const Vec3 foot = pose.ApplyInverse(cam.target);
  const int n = 24;
  const double x0 = std::floor(foot.x() / cell) * cell - n / 2 * cell;
  const double y0 = std::floor(foot.y() / cell) * cell - n / 2 * cell;
  const Vec3 nz = pose.Rotate(Vec3::UnitZ());
  glBegin(GL_QUADS);
  glNormal3d(nz.x(), nz.y(), nz.z());
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const float g = ((i + j) & 1) ? 0.80f : 0.70f;
      const float col[4] = {g, g, g * 1.03f, 1.0f};
      glMaterialfv(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE, col);
      const double xa = x0 + i * cell, ya = y0 + j * cell;
      const Vec3 c[4] = {pose.Apply(Vec3(xa, ya, 0)), pose.Apply(Vec3(xa + cell, ya, 0)),
                         pose.Apply(Vec3(xa + cell, ya + cell, 0)), pose.Apply(Vec3(xa, ya + cell, 0))};
      for (const Vec3& p : c) glVertex3d(p.x(), p.y(), p.z());
    }
  glEnd();
}

// a lit cylinder from a to b
void DrawCylinder(const Vec3& a, const Vec3& b, double radius) {
  const Vec3 axis = b - a;
  const double len = axis.norm();
  if (!(len > 1e-9)) return;
  const Vec3 z = axis / len, x = AnyPerpendicular(z), y = z.cross(x);
  constexpr int n = 12;
  glBegin(GL_QUAD_STRIP);
  for (int i = 0; i <= n; ++i) {
    const double t = 2.0 * M_PI * i / n;
    const Vec3 d = std::cos(t) * x + std::sin(t) * y;
    const Vec3 p = a + radius * d, q = b + radius * d;
    glNormal3d(d.x(), d.y(), d.z());
    glVertex3d(p.x(), p.y(), p.z());
    glVertex3d(q.x(), q.y(), q.z());
  }
  glEnd();
}

// a lit sphere
void DrawBall(const Vec3& c, double radius) {
  constexpr int nl = 8, nm = 12;
  for (int i = 0; i < nl; ++i) {
    const double t0 = M_PI * i / nl, t1 = M_PI * (i + 1) / nl;
    glBegin(GL_QUAD_STRIP);
    for (int j = 0; j <= nm; ++j) {
      const double ph = 2.0 * M_PI * j / nm;
      for (double t : {t0, t1}) {
        const Vec3 d(std::sin(t) * std::cos(ph), std::sin(t) * std::sin(ph), std::cos(t));
        const Vec3 p = c + radius * d;
        glNormal3d(d.x(), d.y(), d.z());
        glVertex3d(p.x(), p.y(), p.z());
      }
    }
    glEnd();
  }
}

// a finger's links as cylinders and its joints as balls, sized from the link
// lengths; `lit`: with the link and joint materials, else in the current colour
void DrawLinks(const FingerState& f, bool lit) {
  const double reach = (f.points[1] - f.points[0]).norm() + (f.points[2] - f.points[1]).norm() +
                       (f.points[3] - f.points[2]).norm();
  const double radius = std::clamp(0.07 * reach, 1e-4, 0.05);
  const float link[4] = {0.55f, 0.58f, 0.64f, 1.0f}, joint[4] = {0.35f, 0.37f, 0.42f, 1.0f};
  if (lit) glMaterialfv(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE, link);
  for (int i = 0; i < 3; ++i) DrawCylinder(f.points[i], f.points[i + 1], radius);
  if (lit) glMaterialfv(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE, joint);
  for (int i = 0; i < 3; ++i) DrawBall(f.points[i], 1.3 * radius);
}

constexpr size_t kShadowStride = 4;

// projects points onto the plane through o with normal n along direction l
// (towards the light): p - ((p - o).n / l.n) l, as a 4x4 matrix
Mat4 ShadowMatrix(const Vec3& o, const Vec3& n, const Vec3& l) {
  const double ln = l.dot(n);
  Mat4 m = Mat4::Identity();
  m.block<3, 3>(0, 0) -= l * n.transpose() / ln;
  m.block<3, 1>(0, 3) = l * (o.dot(n) / ln);
  return m;
}

// one arrow from a along d: a shaft and a two-stroke head facing the camera
void Arrow(const Vec3& a, const Vec3& d, const Camera& cam) {
  const double len = d.norm();
  const Vec3 e = a + d;
  glVertex3d(a.x(), a.y(), a.z());
  glVertex3d(e.x(), e.y(), e.z());
  Vec3 side = d.cross(e - cam.position);
  if (side.norm() < 1e-12) side = AnyPerpendicular(d / len);
  side = side.normalized() * (0.12 * len);
  const Vec3 back = e - 0.25 * d;
  const Vec3 h1 = back + side, h2 = back - side;
  glVertex3d(e.x(), e.y(), e.z());
  glVertex3d(h1.x(), h1.y(), h1.z());
  glVertex3d(e.x(), e.y(), e.z());
  glVertex3d(h2.x(), h2.y(), h2.z());
}

// +1 to show the force on body a (the contact's force), -1 for the one on b: the
// force on the grasped object, a body that is neither fixed nor a fingertip
double ForceSign(const SnapshotRig& rig, int a, int b) {
  auto object = [&](int i) {
    if (i < 0 || i >= static_cast<int>(rig.bodies.size())) return false;
    const SurfaceRig& r = rig.bodies[i];
    return !r.fixed && !r.is_plane && r.finger < 0;
  };
  return !object(a) && object(b) ? -1.0 : 1.0;
}

}  // namespace

Renderer::Renderer() = default;
Renderer::~Renderer() = default;

bool Renderer::Init(int width, int height, std::string* error) {
  if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    *error = "image size " + std::to_string(width) + "x" + std::to_string(height) +
             " is out of range (16 to 8192 pixels each way)";
    return false;
  }
  // no shader cache in ~/.cache: every frame's shaders are few and cheap to compile
  setenv("MESA_SHADER_CACHE_DISABLE", "true", 0);
  ctx_ = std::make_unique<Context>();
  ctx_->ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (!ctx_->ctx) {
    *error = "OSMesa: cannot create an off-screen GL context (is libosmesa6 installed?)";
    return false;
  }
  frame_.Resize(width, height);
  if (!OSMesaMakeCurrent(ctx_->ctx, frame_.rgba.data(), GL_UNSIGNED_BYTE, width, height)) {
    *error = "OSMesa: cannot make the context current";
    return false;
  }
  OSMesaPixelStore(OSMESA_Y_UP, 0);  // row 0 at the top, like image files
  const GLubyte* v = glGetString(GL_VERSION);
  if (!v) {
    *error = "OpenGL calls do nothing (GL_VERSION is null): libGL was linked before libOSMesa";
    return false;
  }
  gl_version_ = reinterpret_cast<const char*>(v);
  return true;
}

std::vector<std::string> HudLines(const HudState& h) {
  std::vector<std::string> lines;
  char buf[128];
  std::snprintf(buf, sizeof buf, "t = %.3f s   step %lld", h.time, static_cast<long long>(h.step));
  lines.emplace_back(buf);
  if (h.step_ms >= 0) {
    std::snprintf(buf, sizeof buf, "step time %.3f ms", h.step_ms);
    lines.emplace_back(buf);
  }
  std::snprintf(buf, sizeof buf, "contacts %d", h.contacts);
  lines.emplace_back(buf);
  std::snprintf(buf, sizeof buf, "iterations %d   residual %.1e%s", h.iterations, h.residual,
                h.converged ? "" : " (cap)");
  lines.emplace_back(buf);
  if (!h.tracker.empty() && h.tracker != "none") lines.emplace_back("tracker " + h.tracker);
  return lines;
}

const Image& Renderer::Draw(const SnapshotRig& rig, const WorldSnapshot& s, const Camera& cam, const Style& style) {
  const auto t0 = Clock::now();
  ExpandSurfaces(rig, s, &surfaces_);
  const auto t1 = Clock::now();
  const int W = frame_.width, H = frame_.height;
  OSMesaMakeCurrent(ctx_->ctx, frame_.rgba.data(), GL_UNSIGNED_BYTE, W, H);
  OSMesaPixelStore(OSMESA_Y_UP, 0);
  glViewport(0, 0, W, H);
  glClearColor(0.92f, 0.94f, 0.97f, 1.0f);
  glClearStencil(0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glMatrixMode(GL_PROJECTION);
  const Mat4 P = cam.Projection(double(W) / H);
  glLoadMatrixd(P.data());
  glMatrixMode(GL_MODELVIEW);
  glLoadIdentity();
  // a key light above-left of the viewer and a fill, fixed in the eye frame
  // (from the upper left: faces up brightest, faces to the right darkest)
  const float key[4] = {-0.6f, 0.7f, 0.9f, 0.0f}, fill[4] = {0.8f, -0.2f, 0.5f, 0.0f};
  const float key_c[4] = {0.80f, 0.79f, 0.76f, 1.0f}, fill_c[4] = {0.28f, 0.29f, 0.32f, 1.0f};
  const float amb[4] = {0.22f, 0.22f, 0.24f, 1.0f};
  glEnable(GL_LIGHTING);
  glEnable(GL_LIGHT0);
  glEnable(GL_LIGHT1);
  glLightfv(GL_LIGHT0, GL_POSITION, key);
  glLightfv(GL_LIGHT0, GL_DIFFUSE, key_c);
  glLightfv(GL_LIGHT1, GL_POSITION, fill);
  glLightfv(GL_LIGHT1, GL_DIFFUSE, fill_c);
  glLightModelfv(GL_LIGHT_MODEL_AMBIENT, amb);
  const Mat4 V = cam.View();
  glLoadMatrixd(V.data());
  const Vec3 view_dir = (cam.target - cam.position).normalized();

  // planes first
  for (size_t b = 0; b < rig.bodies.size() && b < s.bodies.size(); ++b)
    if (rig.bodies[b].is_plane) DrawPlane(s.bodies[b].pose, cam);

  // shadows on the planes: every surface (every kShadowStride-th point, larger
  // splats) and the finger links flattened along a light from above (tilted
  // like the key light), drawn once per pixel (stencil) as a translucent dark
  // layer over the plane, under everything drawn after: it shows how high a
  // lifted object is above the table
  glDisable(GL_LIGHTING);
  for (size_t pb = 0; pb < rig.bodies.size() && pb < s.bodies.size(); ++pb) {
    if (!rig.bodies[pb].is_plane) continue;
    const Pose& pp = s.bodies[pb].pose;
    const Vec3 n = pp.Rotate(Vec3::UnitZ()), o = pp.t;
    const Eigen::Matrix3d eye_to_world = V.block<3, 3>(0, 0).transpose();
    Vec3 tilt = eye_to_world * Vec3(key[0], key[1], key[2]);
    tilt -= tilt.dot(n) * n;
    const Vec3 l = tilt.norm() > 1e-9 ? Vec3((n + 0.35 * tilt.normalized()).normalized()) : n;
    const Mat4 VS = V * ShadowMatrix(o, n, l);
    glLoadMatrixd(VS.data());
    glDisable(GL_DEPTH_TEST);
    glEnable(GL_STENCIL_TEST);
    glStencilFunc(GL_EQUAL, 0, 0xFF);
    glStencilOp(GL_KEEP, GL_KEEP, GL_INCR);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glColor4f(0.05f, 0.06f, 0.10f, 0.5f);
    glEnableClientState(GL_VERTEX_ARRAY);
    for (size_t b = 0; b < rig.bodies.size() && b < s.bodies.size(); ++b) {
      const SurfaceRig& r = rig.bodies[b];
      const SurfaceFrame& f = surfaces_[b];
      if (r.is_plane || f.positions.size() < kShadowStride) continue;
      const double depth = std::max(1e-4, (s.bodies[b].pose.t - cam.position).dot(view_dir));
      const double px = 2.0 * r.spacing * std::sqrt(double(kShadowStride)) * cam.PixelsPerMetre(depth, H);
      glPointSize(static_cast<float>(std::clamp(px, 1.0, 24.0)));
      glVertexPointer(3, GL_DOUBLE, kShadowStride * sizeof(Vec3), f.positions.data());
      glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(f.positions.size() / kShadowStride));
    }
    glDisableClientState(GL_VERTEX_ARRAY);
    for (const FingerState& f : s.fingers) DrawLinks(f, false);
    glDisable(GL_BLEND);
    glDisable(GL_STENCIL_TEST);
    glEnable(GL_DEPTH_TEST);
    glLoadMatrixd(V.data());
    glClear(GL_STENCIL_BUFFER_BIT);
  }
  glEnable(GL_LIGHTING);

  // surfaces as splats: point size from the spacing seen at the body's depth
  glEnableClientState(GL_VERTEX_ARRAY);
  glEnableClientState(GL_NORMAL_ARRAY);
  for (size_t b = 0; b < rig.bodies.size() && b < s.bodies.size(); ++b) {
    const SurfaceRig& r = rig.bodies[b];
    const SurfaceFrame& f = surfaces_[b];
    if (r.is_plane || f.positions.empty()) continue;
    const double depth = std::max(1e-4, (s.bodies[b].pose.t - cam.position).dot(view_dir));
    const double px = 2.3 * r.spacing * cam.PixelsPerMetre(depth, H);
    // whole pixels, rounded up: llvmpipe rounds aliased point sizes to the nearest
    // integer, and a 1.4 px splat drawn as 1 px leaves holes
    glPointSize(static_cast<float>(std::clamp(std::ceil(px), 1.0, 16.0)));
    float col[4];
    BodyColour(r, r.finger >= 0, col);
    glMaterialfv(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE, col);
    glVertexPointer(3, GL_DOUBLE, sizeof(Vec3), f.positions.data());
    glNormalPointer(GL_DOUBLE, sizeof(Vec3), f.normals.data());
    glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(f.positions.size()));
  }
  glDisableClientState(GL_NORMAL_ARRAY);
  glDisableClientState(GL_VERTEX_ARRAY);

  // finger links: lit cylinders and joint balls, sized from the link lengths
  for (const FingerState& f : s.fingers) DrawLinks(f, true);
  glDisable(GL_LIGHTING);

  // force arrows over everything: the force on the grasped object, pushing
  // (the head at the contact point); each drawn over a dark outline so that it
  // reads on the orange object and the pink fingertips alike
  if (style.arrows && !s.contacts.empty()) {
    arrows_.clear();
    if (!style.per_pair) {
      for (const ContactState& c : s.contacts) {
        const Vec3 d = ForceSign(rig, c.body[0], c.body[1]) * style.force_scale * c.force;
        if (!(d.norm() > 1e-7) || !d.allFinite()) continue;
        arrows_.push_back(ArrowItem{c.point - d, d, c.slip});
      }
    } else {
      // contacts come grouped by body pair from collision detection, but do not rely on it
      pairs_.clear();
      for (const ContactState& c : s.contacts) {
        const double m = c.force.norm();
        if (!std::isfinite(m)) continue;
        PairSum* p = nullptr;
        for (PairSum& q : pairs_)
          if (q.a == c.body[0] && q.b == c.body[1]) p = &q;
        if (!p) {
          pairs_.push_back(PairSum{c.body[0], c.body[1]});
          p = &pairs_.back();
        }
        p->force += c.force;
        p->centroid += m * c.point;
        p->weight += m;
        p->slip_weight += c.slip ? m : 0.0;
      }
      for (const PairSum& p : pairs_) {
        const Vec3 d = ForceSign(rig, p.a, p.b) * style.force_scale * p.force;
        if (!(p.weight > 0) || !(d.norm() > 1e-7) || !d.allFinite()) continue;
        arrows_.push_back(ArrowItem{p.centroid / p.weight - d, d, p.slip_weight > 0.5 * p.weight});
      }
    }
    // line width grows with the image: 4 px (pairs) or 2 px (contacts) at 480 rows
    const float width = style.per_pair ? std::max(3.0f, std::round(float(H) / 120.0f))
                                       : std::max(2.0f, std::round(float(H) / 240.0f));
    glDisable(GL_DEPTH_TEST);
    for (int pass = 0; pass < 2; ++pass) {
      glLineWidth(pass == 0 ? width + 2.0f : width);
      glBegin(GL_LINES);
      for (const ArrowItem& a : arrows_) {
        const uint8_t* rgb = a.slip ? kSlipRgb : kStickRgb;
        if (pass == 0)
          glColor3ub(25, 25, 30);
        else
          glColor3ub(rgb[0], rgb[1], rgb[2]);
        Arrow(a.from, a.d, cam);
      }
      glEnd();
    }
    glEnable(GL_DEPTH_TEST);
  }
  glFinish();
  const auto t2 = Clock::now();

  // overlays written into the frame
  const int scale = std::max(1, H / 240);
  if (style.hud) {
    const std::vector<std::string> lines = HudLines(s.hud);
    int wmax = 0;
    for (const std::string& l : lines) wmax = std::max(wmax, TextWidth(l, scale));
    const int lh = TextHeight(scale);
    FillRect(&frame_, 0, 0, wmax + 8 * scale, static_cast<int>(lines.size()) * lh + 6 * scale, Rgb{20, 24, 32}, 0.6);
    for (size_t i = 0; i < lines.size(); ++i)
      DrawText(&frame_, 4 * scale, 2 * scale + static_cast<int>(i) * lh, lines[i], scale,
               Rgb{kHudTextRgb[0], kHudTextRgb[1], kHudTextRgb[2]});
  }
  if (style.legend && style.arrows && style.force_scale > 0) {
    // a bar as long as legend_force's arrow at the target's depth
    const double depth = (cam.target - cam.position).norm();
    const double ppm = cam.PixelsPerMetre(depth, H);
    double f = style.legend_force > 0 ? style.legend_force : RoundValue(0.03 / style.force_scale);
    while (f * style.force_scale * ppm > 0.3 * W && f > 1e-9) f = RoundValue(f / 2.1);
    const int len = std::max(2, static_cast<int>(std::lround(f * style.force_scale * ppm)));
    char label[64];
    std::snprintf(label, sizeof label, "%g N", f);
    const std::string keys = "stick   slip";
    const int lh = TextHeight(scale);
    const int box_w = std::max(len, TextWidth(keys, scale)) + 12 * scale + TextWidth(label, scale);
    const int x0 = W - box_w - 4 * scale, y0 = H - 2 * lh - 10 * scale;
    FillRect(&frame_, x0 - 4 * scale, y0 - 4 * scale, box_w + 8 * scale, 2 * lh + 12 * scale, Rgb{20, 24, 32}, 0.6);
    const Rgb stick{kStickRgb[0], kStickRgb[1], kStickRgb[2]}, slip{kSlipRgb[0], kSlipRgb[1], kSlipRgb[2]};
    const int yb = y0 + lh / 2;
    FillRect(&frame_, x0, yb - scale, len, 2 * scale + 1, stick, 1.0);
    FillRect(&frame_, x0, yb - 3 * scale, scale, 6 * scale + 1, stick, 1.0);
    FillRect(&frame_, x0 + len - scale, yb - 3 * scale, scale, 6 * scale + 1, stick, 1.0);
    DrawText(&frame_, x0 + len + 6 * scale, y0, label, scale, Rgb{255, 255, 255});
    DrawText(&frame_, x0, y0 + lh + 2 * scale, "stick", scale, stick);
    DrawText(&frame_, x0 + TextWidth("stick   ", scale), y0 + lh + 2 * scale, "slip", scale, slip);
  }
  const auto t3 = Clock::now();
  expand_ms_ = Ms(t0, t1);
  draw_ms_ = Ms(t1, t2);
  overlay_ms_ = Ms(t2, t3);
  return frame_;
}

}  // namespace gs::render
