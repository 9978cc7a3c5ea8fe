// The scene's tracked hand, `hand: {model: tracked, ...}` (docs/scene-format.md,
// "Tracked hand"): one free body per segment, a palm box and three capsule
// phalanges per finger, sized from the scene (an average adult hand by default)
// and placed from the hand model at the start pose (core/hand.h); each segment
// follows its tracked segment through the tracker's virtual coupling, and the
// segments of one finger (of the whole hand, without self_contact) never touch.
#include <set>

#include "core/hand.h"
#include "scene/scene_file.h"
#include "tracking/hand_mapping.h"

namespace gs::app {
namespace {

constexpr double kBig = 1e6;
const char* const kFingerNames[kHandMaxFingers] = {"thumb", "index", "middle", "ring", "little"};
const char* const kPhalanxNames[kPhalanges] = {"outer", "middle", "inner"};

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

// `sizes: {thumb: {lengths_m: [outer, middle, inner], radius_m}, ...}`
void ReadSizes(MapReader& parent, HandModel* hm) {
  YAML::Node n = parent.Raw("sizes");
  if (!n) return;
  MapReader m(n, parent.file(), "sizes", parent.errors());
  if (!m.ok()) return;
  for (int f = 0; f < hm->fingers; ++f) {
    YAML::Node fn = m.Raw(kFingerNames[f]);
    if (!fn) continue;
    MapReader k(fn, parent.file(), kFingerNames[f], parent.errors());
    if (!k.ok()) continue;
    Vec3 l(hm->finger[f].length[0], hm->finger[f].length[1], hm->finger[f].length[2]);
    k.Vector3("lengths_m", &l, 0.005, 0.12, false);
    k.Number("radius_m", &hm->finger[f].radius, 0.002, 0.03, false);
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

// the palm box and each finger's phalanx capsules, at the start pose
void AddSegments(const HandModel& hm, const Pose& hand, const Vec3& q, const SegmentDensity& palm,
                 const SegmentDensity& phalanx, const DeformationParams& def, const SceneError& at, Scene* s) {
  SceneTrackedHand& th = s->tracked_hand;
  SceneBody pb = SegmentBody("palm", hand * hm.palm, palm, def, at);
  pb.spec.shape.type = EShape::Box;
  pb.spec.shape.half_extents = 0.5 * hm.palm_size;
  s->bodies.push_back(pb);
  th.segments.push_back({"palm", -1, tracking::ESegment::Palm, hm.palm});
  for (int f = 0; f < hm.fingers; ++f) {
    const FingerChain c = ChainFromTip(PoseFinger(hm, f, hand, q));
    for (int k = 0; k < kPhalanges; ++k) {
      const std::string name = std::string(kFingerNames[f]) + "_" + kPhalanxNames[k];
      SceneBody b = SegmentBody(name, PhalanxCapsulePose(c, static_cast<EPhalanx>(k)), phalanx, def, at);
      b.spec.shape.type = EShape::Capsule;
      b.spec.shape.radius = hm.finger[f].radius;
      b.spec.shape.half_length = 0.5 * hm.finger[f].length[k];
      s->bodies.push_back(b);
      const tracking::ESegment seg = k == 0 ? tracking::ESegment::Outer
                                     : k == 1 ? tracking::ESegment::Middle : tracking::ESegment::Inner;
      th.segments.push_back({name, f, seg, Pose{}});
    }
  }
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
  HandModel hm = AverageAdultHand(fingers == 3 ? 3 : 5, th.right);
  // densities: the palm at the paper's fingertip density, a phalanx at the tracked
  // fingertips' (config/tracked_hand.yaml), so that a grasp's step fits in 1 ms
  SegmentDensity palm{2400, 320, 0.1, true}, phalanx{400, 50, 0.02, true};
  ReadDensity(m, "palm", &palm, &hm.palm_size, &hm.palm);
  ReadDensity(m, "phalanx", &phalanx, nullptr, nullptr);
  ReadSizes(m, &hm);
  // the skin of config/tracked_hand.yaml's fingertips unless the scene says otherwise
  DeformationParams def;
  def.model = EDeformation::Gaussian;
  def.stiffness = 300.0;
  def.damping = 1.0;
  def.influence_radius = 0.003;
  ReadDeformation(m, &def);
  m.Finish();
  AddSegments(hm, Pose{RotationDeg(rot), pos}, q, palm, phalanx, def, th.at, s);
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
      // an inner phalanx meets the palm at its knuckle; the thumb's inner and middle
      // phalanges lie in the ball of the thumb, which the palm box covers
      const auto rooted = [](const SceneHandSegment& s) {
        return s.segment == tracking::ESegment::Inner || (s.finger == 0 && s.segment == tracking::ESegment::Middle);
      };
      const bool knuckle = (a.finger < 0 && rooted(b)) || (b.finger < 0 && rooted(a));
      if (same_finger || knuckle || !th.self_contact) w.SetCanTouch(index[i], index[j], false);
    }
}

}  // namespace gs::app
