// The scene's tracked hand, `hand: {model: tracked, ...}` (docs/scene-format.md,
// "Tracked hand"): one free body per segment, a palm box and three capsule
// phalanges per finger, sized from the scene (an average adult hand by default)
// and placed from the hand model at the start pose (core/hand.h); each segment
// follows its tracked segment through the tracker's virtual coupling, and the
// segments of one finger (of the whole hand, without self_contact) never touch.
#include <algorithm>
#include <array>
#include <cstdio>
#include <set>

#include "core/hand.h"
#include "scene/scene_file.h"
#include "tracking/hand_mapping.h"

namespace gs::app {
namespace {

constexpr double kBig = 1e6;
const char* const kFingerNames[kHandMaxFingers] = {"thumb", "index", "middle", "ring", "little"};
const char* const kPhalanxNames[kPhalanges] = {"outer", "middle", "inner"};
// a phalanx capsule's sizes, from the scene or from the tracker (m)
constexpr double kMinLength = 0.005, kMaxLength = 0.12, kMinRadius = 0.002, kMaxRadius = 0.03;
constexpr double kMaxKnuckle = 0.15;  ///< m from the back of the hand's origin (the average hand's farthest: 6 cm)

SceneError At(SceneError at, const std::string& message) {
  at.message = message;
  return at;
}

Mat3 RotationDeg(const Vec3& deg) {
  const Vec3 r = deg * (M_PI / 180.0);
  return (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

// what every segment of one kind (the palm, or a phalanx) shares
struct SegmentDensity {
  int64_t points = 0, control_points = 0;
  double mass = 0.0;
  bool contact_points = true;  ///< two-pass contact, as a body's `contact_points`
};

void ReadDensity(MapReader& parent, const char* key, SegmentDensity* d, Vec3* palm_size, Pose* palm_offset) {
  YAML::Node n = parent.Raw(key);
  if (!n) return;
  MapReader m(n, parent.file(), key, parent.errors());
  if (!m.ok()) return;
  m.Integer("points", &d->points, 4, 2000000, false);
  m.Integer("control_points", &d->control_points, 1, 2000000, false);
  m.Number("mass_kg", &d->mass, 0, kBig, false, true);
  m.Flag("contact_points", &d->contact_points, false);
  if (palm_size) {
    m.Vector3("size_m", palm_size, 1e-4, 1.0, false);
    m.Vector3("offset_m", &palm_offset->t, -1.0, 1.0, false);
  }
  if (d->control_points > d->points) m.Error(m.Raw("control_points"), "'control_points' cannot exceed 'points'");
  m.Finish();
}

// `sizes: tracker`, or `sizes: {thumb: {lengths_m: [outer, middle, inner], radius_m}, ...}`
void ReadSizes(MapReader& parent, SceneTrackedHand* th, HandModel* hm) {
  YAML::Node n = parent.Raw("sizes");
  if (!n) return;
  if (n.IsScalar()) {
    if (n.Scalar() == "tracker") {
      th->sizes_from_tracker = true;
      th->sizes_at = ErrorAt(parent.file(), n, "");
    } else {
      parent.Error(n, "'sizes' must be 'tracker' (the phalanx lengths and fingertip radii the tracker measures) or "
                      "a map of fingers, like {index: {lengths_m: [0.022, 0.027, 0.043], radius_m: 0.008}}");
    }
    return;
  }
  MapReader m(n, parent.file(), "sizes", parent.errors());
  if (!m.ok()) return;
  for (int f = 0; f < hm->fingers; ++f) {
    YAML::Node fn = m.Raw(kFingerNames[f]);
    if (!fn) continue;
    MapReader k(fn, parent.file(), kFingerNames[f], parent.errors());
    if (!k.ok()) continue;
    Vec3 l(hm->finger[f].length[0], hm->finger[f].length[1], hm->finger[f].length[2]);
    k.Vector3("lengths_m", &l, kMinLength, kMaxLength, false);
    k.Number("radius_m", &hm->finger[f].radius, kMinRadius, kMaxRadius, false);
    for (int p = 0; p < kPhalanges; ++p) hm->finger[f].length[p] = l[p];
    k.Finish();
  }
  m.Finish();
}

SceneBody SegmentBody(const std::string& name, const Pose& pose, const SegmentDensity& d, const DeformationParams& def,
                      const SceneError& at) {
  SceneBody b;
  b.spec.name = name;
  b.spec.pose = pose;
  b.spec.motion = EMotion::Free;
  b.spec.mass = d.mass;
  b.spec.deformation = def;
  b.spec.geometry.points = static_cast<int>(d.points);
  b.spec.geometry.control_points = static_cast<int>(d.control_points);
  b.spec.emits_contacts = d.contact_points;
  b.at = b.position_at = b.shape_at = b.bandwidth_at = at;
  return b;
}

std::string PhalanxBodyName(int f, int k) { return std::string(kFingerNames[f]) + "_" + kPhalanxNames[k]; }

// every phalanx capsule's pose, radius and length from the hand's sizes at its start pose
void ShapePhalanges(Scene* s) {
  const SceneTrackedHand& th = s->tracked_hand;
  for (int f = 0; f < th.model.fingers; ++f) {
    const FingerChain c = ChainFromTip(PoseFinger(th.model, f, th.start, th.start_flexion));
    for (int k = 0; k < kPhalanges; ++k)
      for (SceneBody& b : s->bodies) {
        if (b.spec.name != PhalanxBodyName(f, k)) continue;
        b.spec.pose = PhalanxCapsulePose(c, static_cast<EPhalanx>(k));
        b.spec.shape.type = EShape::Capsule;
        b.spec.shape.radius = th.model.finger[f].radius;
        b.spec.shape.half_length = 0.5 * th.model.finger[f].length[k];
      }
  }
}

// the palm box and each finger's phalanx capsules, at the start pose
void AddSegments(const SegmentDensity& palm, const SegmentDensity& phalanx, const DeformationParams& def, Scene* s) {
  SceneTrackedHand& th = s->tracked_hand;
  const HandModel& hm = th.model;
  SceneBody pb = SegmentBody("palm", th.start * hm.palm, palm, def, th.at);
  pb.spec.shape.type = EShape::Box;
  pb.spec.shape.half_extents = 0.5 * hm.palm_size;
  s->bodies.push_back(pb);
  th.segments.push_back({"palm", -1, tracking::ESegment::Palm, hm.palm});
  for (int f = 0; f < hm.fingers; ++f) {
    for (int k = 0; k < kPhalanges; ++k) {
      const std::string name = PhalanxBodyName(f, k);
      SceneBody b = SegmentBody(name, Pose{}, phalanx, def, th.at);
      b.spec.motion = EMotion::Fingertip;  // carried by its finger's joints (AddTrackedFingers)
      s->bodies.push_back(b);
      const tracking::ESegment seg = k == 0 ? tracking::ESegment::Outer
                                     : k == 1 ? tracking::ESegment::Middle : tracking::ESegment::Inner;
      th.segments.push_back({name, f, seg, Pose{}});
    }
  }
  ShapePhalanges(s);
}

// why finger f of a gl hand cannot size a phalanx capsule (the tracker's checks, then
// the scene's limits), or "": the sizes in metres into *out
std::string FingerSizeProblem(const tracking::Hand& hand, int f, const tracking::TrackerConfig& c,
                              HandFingerModel* out) {
  const tracking::HandFinger& g = hand.fingers[f];
  char values[160];
  std::snprintf(values, sizeof values, " (phalanges %g, %g, %g, fingertip radius %g, in tracker units of %g m)",
                g.phalanx_length[0], g.phalanx_length[1], g.phalanx_length[2], g.tip_radius, c.units_m);
  const std::string finger = std::string(kFingerNames[f]) + " (finger " + std::to_string(f) + ")";
  TrackedFinger tf;
  if (const char* problem = tracking::GlFinger(g, c, &tf)) return finger + ": " + problem + values;
  out->radius = g.tip_radius * c.units_m;
  if (!(out->radius >= kMinRadius && out->radius <= kMaxRadius))
    return finger + ": the fingertip radius is outside the scene's 2 to 30 mm for a phalanx capsule" + values;
  for (int k = 0; k < kPhalanges; ++k) {
    out->length[k] = g.phalanx_length[k] * c.units_m;
    if (!(out->length[k] >= kMinLength && out->length[k] <= kMaxLength))
      return finger + ": a phalanx length is outside the scene's 5 to 120 mm for a phalanx capsule" + values;
  }
  // the knuckle (root joint) where the tracker's chain puts it, in the back of the
  // hand's frame: the finger's joints are rooted there on the palm, so that the
  // tracked inner phalanx and the simulated one start at the same point
  const Vec3 knuckle = hand.rotation.transpose() * (ChainFromTip(tf).joint[kPhalanges] - hand.position) * c.units_m;
  if (!(knuckle.norm() <= kMaxKnuckle)) {
    char where[96];
    std::snprintf(where, sizeof where, ": its knuckle lies %.0f mm from the back of the hand; at most %.0f mm",
                  1e3 * knuckle.norm(), 1e3 * kMaxKnuckle);
    return finger + where + values;
  }
  out->root.t = knuckle;
  return "";
}

// how much wider the tracked knuckles of the four fingers spread across the hand (y)
// than the model's: the palm box is made as much wider (a three-finger glove's two
// knuckles, and a ratio outside 0.5 to 2, leave it as it is)
double KnuckleSpreadRatio(const HandModel& tracked, const HandModel& model) {
  if (tracked.fingers < 5) return 1.0;
  const auto spread = [](const HandModel& m) {
    double lo = 1e9, hi = -1e9;
    for (int f = 1; f < m.fingers; ++f) {
      lo = std::min(lo, m.finger[f].root.t.y());
      hi = std::max(hi, m.finger[f].root.t.y());
    }
    return hi - lo;
  };
  const double ratio = spread(tracked) / spread(model);
  return ratio >= 0.5 && ratio <= 2.0 ? ratio : 1.0;
}

}  // namespace

void ReadTrackedHand(const YAML::Node& node, const std::string& file, Scene* s, std::vector<SceneError>* errors) {
  MapReader m(node, file, "hand", errors);
  if (!m.ok()) return;
  SceneTrackedHand& th = s->tracked_hand;
  th.enabled = true;
  th.at = ErrorAt(file, node, "");
  std::string model, side = "right";
  m.Choice("model", &model, {"tracked"}, true);
  int64_t fingers = 5;
  if (m.Integer("fingers", &fingers, 3, 5, false) && fingers == 4)
    m.Error(m.Raw("fingers"), "'fingers' must be 5 (thumb to little) or 3 (a three-finger glove: thumb, index, middle)");
  m.Choice("side", &side, {"right", "left"}, false);
  th.right = side == "right";
  m.Flag("self_contact", &th.self_contact, false);
  Vec3 pos = Vec3::Zero(), rot = Vec3::Zero(), q = Vec3::Zero();
  m.Vector3("position_m", &pos, -kBig, kBig, false);
  m.Vector3("rotation_deg", &rot, -1e4, 1e4, false);
  m.Vector3("start_flexion_rad", &q, -M_PI, M_PI, false);
  th.model = AverageAdultHand(fingers == 3 ? 3 : 5, th.right);
  HandModel& hm = th.model;
  // densities: the palm at the paper's fingertip density, a phalanx at the tracked
  // fingertips' (config/tracked_hand.yaml), so that a grasp's step fits in 1 ms
  SegmentDensity palm{2400, 320, 0.1, true}, phalanx{400, 50, 0.02, true};
  if (YAML::Node pn = m.Raw("palm"); pn && pn.IsMap() && pn["size_m"]) th.palm_size_given = true;
  ReadDensity(m, "palm", &palm, &hm.palm_size, &hm.palm);
  ReadDensity(m, "phalanx", &phalanx, nullptr, nullptr);
  ReadSizes(m, &th, &hm);
  // the skin of config/tracked_hand.yaml's fingertips unless the scene says otherwise
  DeformationParams def;
  def.model = EDeformation::Gaussian;
  def.stiffness = 300.0;
  def.damping = 1.0;
  def.influence_radius = 0.003;
  ReadDeformation(m, &def);
  m.Finish();
  th.start = Pose{RotationDeg(rot), pos};
  th.start_flexion = q;
  AddSegments(palm, phalanx, def, s);
}

bool SizeHandFromFrame(const tracking::DTrackFrame& frame, Scene* s, std::string* why) {
  SceneTrackedHand& th = s->tracked_hand;
  const tracking::TrackerConfig& c = s->tracker;
  const std::string hand_name = "hand " + std::to_string(c.hand_id);
  const tracking::Hand* hand = frame.FindHand(c.hand_id);
  if (!hand) {
    *why = "no gl line with " + hand_name;
    return false;
  }
  if (hand->right != th.right) {
    *why = hand_name + " is a " + (hand->right ? "right" : "left") + " hand; the scene's is " +
           (th.right ? "right" : "left");
    return false;
  }
  if (!hand->tracked()) {
    *why = hand_name + " is not tracked";
    return false;
  }
  if (hand->num_fingers < th.model.fingers) {
    *why = hand_name + " has " + std::to_string(hand->num_fingers) + " fingers; the scene's hand has " +
           std::to_string(th.model.fingers);
    return false;
  }
  HandModel sized = th.model;
  for (int f = 0; f < th.model.fingers; ++f) {
    const std::string problem = FingerSizeProblem(*hand, f, c, &sized.finger[f]);
    if (!problem.empty()) {
      *why = hand_name + ", " + problem;
      return false;
    }
  }
  if (!th.palm_size_given) sized.palm_size.y() *= KnuckleSpreadRatio(sized, th.model);
  th.model = sized;
  th.sized = true;
  ShapePhalanges(s);
  for (SceneBody& b : s->bodies)
    if (b.spec.name == "palm") b.spec.shape.half_extents = 0.5 * th.model.palm_size;
  return true;
}

void PlaceTrackedHand(Scene* s, const Pose& start, const Vec3& flexion) {
  SceneTrackedHand& th = s->tracked_hand;
  if (!th.enabled) return;
  th.start = start;
  th.start_flexion = flexion;
  ShapePhalanges(s);
  for (SceneBody& b : s->bodies)
    if (b.spec.name == "palm") b.spec.pose = th.start * th.model.palm;
}

void AddTrackedHandTargets(Scene* s, std::vector<SceneError>* errors) {
  const SceneTrackedHand& th = s->tracked_hand;
  tracking::TrackerConfig& c = s->tracker;
  if (!s->has_tracker) {
    errors->push_back(At(th.at, "a tracked hand ('model: tracked') needs a 'tracker:' section with 'source: hand'"));
    return;
  }
  if (c.source != tracking::ESource::Hand) {
    errors->push_back(At(th.at, "a tracked hand follows a gl Fingertracking hand: the tracker's 'source' must be 'hand'"));
    return;
  }
  const size_t total = c.fingertips.size() + th.segments.size();
  if (total > static_cast<size_t>(tracking::TargetSample::kMaxTips)) {
    errors->push_back(At(th.at, "the tracked hand's " + std::to_string(th.segments.size()) + " segments and the " +
                                      std::to_string(c.fingertips.size()) + " tracked fingertips make " +
                                      std::to_string(total) + " targets; at most " +
                                      std::to_string(tracking::TargetSample::kMaxTips) +
                                      " (drop the tracker's fingertips)"));
    return;
  }
  c.hand_side = th.right ? 1 : 0;
  for (const SceneHandSegment& seg : th.segments) {
    tracking::FingertipMap f;
    f.name = f.body = seg.body;
    f.finger = seg.finger;
    f.segment = seg.segment;
    f.offset = seg.offset;
    c.fingertips.push_back(f);
  }
}

namespace {

// anatomical joint ranges (rad) of (abduction, root, middle-inner, outer-middle):
// flexion positive toward the pad, a little hyperextension allowed at each joint
constexpr std::array<std::array<double, 2>, 4> kFingerLimits{{{-0.35, 0.35}, {-0.5, 1.75}, {-0.2, 1.95}, {-0.35, 1.6}}};
constexpr std::array<std::array<double, 2>, 4> kThumbLimits{{{-0.6, 0.6}, {-1.0, 1.6}, {-0.3, 2.0}, {-0.5, 2.0}}};
// joint damping of a whole-hand finger (N m s/rad): small against the couplings'
// (8 N s/m at a 5 cm lever: 0.02), it keeps a finger whose segments all released
// from going singular. Measured, not adopted: 1e-2 also conditions the budget-bound
// live solve (9 unconverged steps over three cycles of the synthetic power grasp at 25
// sweeps, against 323) but the pinch then no longer lets go at 0.98 mu*; the shipped
// scenes allow 50 sweeps instead (docs/benchmarks.md)
constexpr double kJointDamping = 1e-4;

int BodyIndex(const World& w, const std::string& name) {
  for (size_t i = 0; i < w.bodies.size(); ++i)
    if (w.bodies[i].name == name) return static_cast<int>(i);
  return -1;
}

// finger f of the hand model as a core Finger: the base at its root joint (the
// inner phalanx frame turned half a turn about x, so that the finger's flexions
// curl toward the pad as the tracker's do), links inner, middle, outer, each
// carrying its phalanx capsule where the start pose puts it
Finger TrackedFingerJoints(const SceneTrackedHand& th, int f, const std::array<int, 3>& segment_bodies) {
  const HandFingerModel& fm = th.model.finger[f];
  Finger fg;
  fg.name = kFingerNames[f];
  fg.model.base = Pose{fm.root.R * Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix(), fm.root.t};
  fg.model.link_lengths = {fm.length[2], fm.length[1], fm.length[0]};
  fg.model.limits = f == 0 ? kThumbLimits : kFingerLimits;
  fg.q = fg.q_target = ClampJoints(fg.model, Vec4(0.0, th.start_flexion.x(), th.start_flexion.y(), th.start_flexion.z()));
  fg.motor_stiffness = fg.motor_damping = 0.0;
  fg.joint_damping = kJointDamping;
  const FingerKinematics k = FingerForward(fg.model, th.start, fg.q);
  const Vec3 q_model(fg.q[1], fg.q[2], fg.q[3]);
  const FingerChain c = ChainFromTip(PoseFinger(th.model, f, th.start, q_model));
  for (int l = 0; l < 3; ++l) {
    fg.segment_body[l] = segment_bodies[l];
    fg.segment_offset[l] = k.link[l].Inverse() * PhalanxCapsulePose(c, static_cast<EPhalanx>(2 - l));
  }
  return fg;
}

}  // namespace

void AddTrackedFingers(const Scene& scene, World& w) {
  const SceneTrackedHand& th = scene.tracked_hand;
  if (!th.enabled) return;
  w.hand.pose = th.start;
  w.hand.carrier = BodyIndex(w, "palm");
  w.hand.carrier_offset = th.model.palm.Inverse();
  for (int f = 0; f < th.model.fingers; ++f) {
    std::array<int, 3> bodies;
    for (int l = 0; l < 3; ++l) bodies[l] = BodyIndex(w, PhalanxBodyName(f, 2 - l));
    if (bodies[0] < 0 || bodies[1] < 0 || bodies[2] < 0) continue;
    w.hand.fingers.push_back(TrackedFingerJoints(th, f, bodies));
  }
}

void ExcludeHandPairs(const Scene& scene, World& w) {
  const SceneTrackedHand& th = scene.tracked_hand;
  if (!th.enabled) return;
  std::vector<int> index(th.segments.size(), -1);
  for (size_t i = 0; i < th.segments.size(); ++i)
    for (size_t b = 0; b < w.bodies.size(); ++b)
      if (w.bodies[b].name == th.segments[i].body) index[i] = static_cast<int>(b);
  for (size_t i = 0; i < th.segments.size(); ++i)
    for (size_t j = i + 1; j < th.segments.size(); ++j) {
      const SceneHandSegment &a = th.segments[i], &b = th.segments[j];
      if (index[i] < 0 || index[j] < 0) continue;
      const bool same_finger = a.finger >= 0 && a.finger == b.finger;
      // an inner phalanx meets the palm at its knuckle. The thumb is rooted inside the
      // palm box (in the ball of the thumb, which the box covers) and its outer
      // phalanx lies along the box's edge when straight and sweeps through the box
      // in opposition: the thumb and the palm box never touch (with that contact the
      // synthetic power grasp's tracked thumb pressed 12 mm into the palm and threw
      // the fingers about: docs/scene-format.md, self_contact)
      const auto rooted = [](const SceneHandSegment& s) {
        return s.segment == tracking::ESegment::Inner || s.finger == 0;
      };
      const bool knuckle = (a.finger < 0 && rooted(b)) || (b.finger < 0 && rooted(a));
      if (same_finger || knuckle || !th.self_contact) w.SetCanTouch(index[i], index[j], false);
    }
}

}  // namespace gs::app
