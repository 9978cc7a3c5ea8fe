// The slide validation: a fingertip pressed on a fixed box's flat top face with a
// constant force is dragged along it at constant speed. Sliding, every contact
// carries mu times its normal force against the motion, so the tangential force on
// the fingertip over its normal force is mu, step after step: a smooth face gives
// no ledges (normals tilted where the face's control points meet the fingertip
// would show as a ripple at the control-point spacing). Both contact modes, soft
// and rigid fingertips.
//
// Coulomb's law is per contact: a sliding contact carries mu times its normal
// force, a sticking one (zero slip velocity) at most that. A soft fingertip in
// two-pass contact has steps where one of the face's contacts on it sticks while
// its skin stretches under it (the contact moves across the skin as the tip
// slides); the sum then carries less than mu N, as Coulomb's law allows. So the
// measure is the worst step whose every contact slides (there the sum is mu N
// exactly), the worst step above mu (added grip, wrong in every step) and the
// mean over the window; the steps with a sticking contact are counted and their
// deepest dip reported.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "validate/validation_util.h"
#include "core/world.h"
#include "session/console.h"

namespace gs::app {

namespace {

constexpr double kMu = 0.5;
constexpr double kPress = 1.0;      // N, the drive's force down
constexpr double kTipRadius = 0.008;
constexpr double kSpeed = 0.02;     // m/s
constexpr double kSettle = 0.2;     // s pressed before the drag
constexpr double kRamp = 0.2;       // s to reach the speed (then the measure begins)

struct SlideRun {
  bool finite = true;
  bool converged = true;   // every step's solve met its tolerance
  double mean = 0.0;       // mean tangential / normal force over the window
  double worst = 0.0;      // largest |ratio - mu| / mu of a step whose contacts all slide, or above mu
  double min = 0.0, max = 0.0;
  int steps = 0;
  int stick_steps = 0;     // steps with a loaded contact inside its cone
};

// a contact carrying at least 1% of the load strictly inside its cone (by 0.1%)
bool SomeContactSticks(const World& w, double load) {
  for (const ContactRow& row : w.rows) {
    if (row.r[0] > 0.01 * load && row.r.tail<2>().norm() < 0.999 * row.mu * row.r[0]) return true;
  }
  return false;
}

int AddBox(World& w, bool two_pass) {
  BodySpec b;
  b.name = "box";
  b.shape.type = EShape::Box;
  b.shape.half_extents = Vec3(0.03, 0.03, 0.01);
  b.geometry.points = 10000;  // ~1.1 mm spacing, the pinch prism's
  b.geometry.control_points = 1250;
  b.motion = EMotion::Fixed;
  b.pose = Pose::Translation(Vec3(0, 0, -0.01));  // top face at z = 0
  b.emits_contacts = two_pass;
  return AddBody(w, b);
}

int AddTip(World& w, bool rigid) {
  BodySpec t;
  t.name = "tip";
  t.shape.type = EShape::Sphere;
  t.shape.radius = kTipRadius;
  t.geometry.points = 2400;
  t.geometry.control_points = 320;
  t.mass = 0.01;
  if (!rigid) {
    t.deformation.model = EDeformation::Gaussian;
    t.deformation.stiffness = 300;
    t.deformation.damping = 0.5;
    t.deformation.influence_radius = 0.0015;
  }
  // 0.2 mm inside touching; pushed down with kPress, stiff across
  t.pose = Pose::Translation(Vec3(-0.015, 0, kTipRadius - 0.0002));
  t.drive.enabled = true;
  t.drive.stiffness = Vec3(3000, 3000, 0);
  t.drive.damping = Vec3(20, 20, 0.5);
  t.drive.angular_stiffness = Vec3::Constant(0.5);
  t.drive.angular_damping = Vec3::Constant(0.01);
  t.drive.force = Vec3(0, 0, -kPress);
  t.drive.target = t.pose;
  return AddBody(w, t);
}

// the contact force on body `tip` (world, N)
Vec3 ForceOn(const World& w, int tip) {
  Vec3 f = Vec3::Zero();
  for (const ContactRow& row : w.rows) {
    if (row.contact.body[0] == tip) f += row.frame.transpose() * row.r;
    if (row.contact.body[1] == tip) f -= row.frame.transpose() * row.r;
  }
  return f;
}

SlideRun RunSlide(bool two_pass, bool rigid, double window) {
  World w;
  w.params.dt = 1e-3;
  const int box = AddBox(w, two_pass);
  const int tip = AddTip(w, rigid);
  SlideRun r;
  if (box < 0 || tip < 0) {
    r.finite = false;
    return r;
  }
  w.Finalize();
  w.SetFriction(tip, box, kMu);
  const Pose start = w.bodies[tip].drive.target;
  const int steps = static_cast<int>(std::lround((kSettle + kRamp + window) / w.params.dt));
  r.min = INFINITY;
  r.max = -INFINITY;
  double sum = 0.0;
  for (int i = 0; i < steps; ++i) {
    const double t = w.time + w.params.dt;
    // the target accelerates uniformly over the ramp, then moves at kSpeed
    const double tr = std::clamp(t - kSettle, 0.0, kRamp);
    const double x = kSpeed * (0.5 * tr * tr / kRamp + std::max(0.0, t - kSettle - kRamp));
    w.bodies[tip].drive.target = start;
    w.bodies[tip].drive.target.t.x() += x;
    w.Step();
    if (StopRequested()) break;  // Ctrl-C: the case ends here, reported as interrupted
    const Vec3 f = ForceOn(w, tip);
    r.finite &= f.allFinite();
    if (t < kSettle + kRamp + 0.5 * w.params.dt) continue;
    r.converged &= w.profile.converged;
    const double ratio = f.z() > 0.0 ? -f.x() / f.z() : INFINITY;  // friction acts against +x
    r.min = std::min(r.min, ratio);
    r.max = std::max(r.max, ratio);
    const bool sticks = SomeContactSticks(w, f.z());
    r.stick_steps += sticks ? 1 : 0;
    r.worst = std::max(r.worst, sticks ? (ratio - kMu) / kMu : std::abs(ratio - kMu) / kMu);
    sum += ratio;
    ++r.steps;
  }
  r.mean = r.steps > 0 ? sum / r.steps : NAN;
  r.worst = std::max(r.worst, std::abs(r.mean - kMu) / kMu);
  return r;
}

}  // namespace

std::vector<ValidationResult> ValidateSlide(const ValidationOptions& opt) {
  std::vector<ValidationResult> out;
  const double window = opt.quick ? 0.5 : 1.5;  // 1 or 3 cm of sliding (3 to 10 control-point spacings)
  for (int rigid = 0; rigid < 2; ++rigid) {
    for (int two_pass = 1; two_pass >= 0 && !StopRequested(); --two_pass) {
      const SlideRun s = RunSlide(two_pass != 0, rigid != 0, window);
      char d[400];
      std::snprintf(d, sizeof d,
                    "%d steps sliding at %.3g m/s: F_t / F_n mean %.5f, min %.5f, max %.5f (mu %.3g; worst step "
                    "with every contact sliding, or above mu, %.3g%% off, limit 1%%; %d steps with a sticking "
                    "contact)%s",
                    s.steps, kSpeed, s.mean, s.min, s.max, kMu, 100.0 * s.worst, s.stick_steps,
                    s.converged ? "" : ", some solves unconverged");
      const std::string mode = two_pass ? "two-pass" : "one-pass";
      const std::string name = std::string("slide_flat_") + (rigid ? "rigid" : "soft") + "_" + mode;
      out.push_back(Result(name, s.finite && s.converged && s.steps > 0 ? s.worst : INFINITY, 0.01, "relative", d, mode));
    }
  }
  return out;
}

}  // namespace gs::app
