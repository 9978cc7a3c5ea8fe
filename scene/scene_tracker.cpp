// The scene file's `tracker:` section (docs/tracking.md): receiving, mapping
// tracked fingers or bodies to fingertip bodies, coupling, live publishing.
#include <arpa/inet.h>

#include <set>

#include "scene/scene_file.h"

namespace gs::app {
namespace {

constexpr double kInf = 1e300;
constexpr double kBig = 1e6;

Mat3 RotationDeg(const Vec3& deg) {
  const Vec3 r = deg * (M_PI / 180.0);
  return (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

bool IsIpv4(const std::string& s) {
  in_addr a;
  return inet_pton(AF_INET, s.c_str(), &a) == 1;
}

}  // namespace

void ReadTrackerSection(const YAML::Node& node, const std::string& file, Scene* s, std::vector<SceneError>* errors) {
  MapReader m(node, file, "tracker", errors);
  if (!m.ok()) return;
  s->has_tracker = true;
  tracking::TrackerConfig& c = s->tracker;
  int64_t port = c.port, hand = c.hand_id;
  m.Integer("port", &port, 1, 65535, false);
  c.port = static_cast<int>(port);
  if (m.Text("multicast_group", &c.multicast_group, false)) {
    in_addr a;
    if (inet_pton(AF_INET, c.multicast_group.c_str(), &a) != 1 || (ntohl(a.s_addr) >> 28) != 0xE)
      m.Error(m.Raw("multicast_group"), "'multicast_group' must be an IPv4 multicast address (224.0.0.0 to 239.255.255.255)");
  }
  if (YAML::Node n = m.Raw("allowed_senders")) {
    if (!n.IsSequence()) {
      m.Error(n, "'allowed_senders' must be a list of IPv4 addresses");
    } else {
      for (const YAML::Node& a : n) {
        if (!a.IsScalar() || !IsIpv4(a.Scalar()))
          m.Error(a, "'allowed_senders' items must be IPv4 addresses like 192.168.0.10");
        else
          c.allowed_senders.push_back(a.Scalar());
      }
    }
  }
  if (m.Text("controller", &c.controller, false) && !IsIpv4(c.controller))
    m.Error(m.Raw("controller"), "'controller' must be the Controller's IPv4 address");
  std::string source = "hand", up = "z";
  m.Choice("source", &source, {"hand", "bodies"}, false);
  c.source = source == "hand" ? tracking::ESource::Hand : tracking::ESource::Bodies;
  m.Integer("hand_id", &hand, 0, 1 << 20, false);
  c.hand_id = static_cast<int>(hand);
  m.Choice("room_up", &up, {"z", "y"}, false);
  c.up = up == "z" ? tracking::EUpAxis::Z : tracking::EUpAxis::Y;
  m.Number("units_m", &c.units_m, 0, 1e3, false, true);
  if (YAML::Node n = m.Raw("calibration")) {
    MapReader k(n, file, "calibration", errors);
    Vec3 pos = Vec3::Zero(), rot = Vec3::Zero();
    k.Vector3("position_m", &pos, -kBig, kBig, false);
    k.Vector3("rotation_deg", &rot, -1e4, 1e4, false);
    k.Finish();
    c.calibration = Pose{RotationDeg(rot), pos};
  }
  m.Number("lost_timeout_s", &c.lost_timeout_s, 0, 1e6, false, true);
  m.Flag("interpolate", &c.interpolate, false);
  m.Number("max_interpolation_s", &c.max_interpolation_s, 0, 10, false, true);
  if (YAML::Node n = m.Raw("coupling")) {
    MapReader k(n, file, "coupling", errors);
    CouplingParams& p = c.coupling;
    k.Number("stiffness_N_m", &p.stiffness, 0, kInf, false);
    k.Number("damping_N_s_m", &p.damping, 0, kInf, false);
    k.Number("angular_stiffness_N_m_rad", &p.angular_stiffness, 0, kInf, false);
    k.Number("angular_damping_N_m_s_rad", &p.angular_damping, 0, kInf, false);
    k.Number("max_force_N", &p.max_force, 0, kInf, false, true);
    k.Number("max_torque_N_m", &p.max_torque, 0, kInf, false, true);
    k.Flag("gravity_compensation", &p.gravity_compensation, false);
    k.Finish();
    if (!(p.stiffness > 0 || p.damping > 0)) k.Error("the coupling needs a positive stiffness or damping");
  }
  if (YAML::Node n = m.Raw("publish")) {
    MapReader k(n, file, "publish", errors);
    k.Number("rate_hz", &c.publish_rate_hz, 0, 1e5, false, true);
    k.Text("lcm_url", &c.lcm_url, false);
    k.Finish();
  }
  YAML::Node tips = m.Raw("fingertips");
  if (!tips) {
    // a tracked hand's segments are targets of their own (AddTrackedHandTargets)
    if (!s->tracked_hand.enabled) m.Error("missing required key 'fingertips' in tracker");
  } else if (!tips.IsSequence() || tips.size() < 1 || tips.size() > 5) {
    m.Error(tips, "'fingertips' must be a list of 1 to 5 fingertips");
  } else {
    std::set<std::string> names, bodies;
    std::set<int64_t> sources;
    for (const YAML::Node& t : tips) {
      MapReader k(t, file, "a tracked fingertip", errors);
      if (!k.ok()) continue;
      tracking::FingertipMap f;
      k.Text("name", &f.name, true);
      k.Text("body", &f.body, true);
      int64_t index = 0;
      if (c.source == tracking::ESource::Hand) {
        k.Integer("finger", &index, 0, 4, true);
        f.finger = static_cast<int>(index);
        if (k.Has("body_id")) k.Error(k.Raw("body_id"), "'body_id' is for source: bodies; a hand's fingertip takes 'finger'");
      } else {
        k.Integer("body_id", &index, 0, 1 << 20, true);
        f.body_id = static_cast<int>(index);
        if (k.Has("finger")) k.Error(k.Raw("finger"), "'finger' is for source: hand; a 6d body takes 'body_id'");
      }
      Vec3 off = Vec3::Zero(), rot = Vec3::Zero();
      k.Vector3("offset_m", &off, -kBig, kBig, false);
      k.Vector3("offset_rotation_deg", &rot, -1e4, 1e4, false);
      f.offset = Pose{RotationDeg(rot), off};
      if (!f.name.empty() && !names.insert(f.name).second) k.Error(t, "duplicate tracked fingertip name '" + f.name + "'");
      if (!f.body.empty() && !bodies.insert(f.body).second) k.Error(t, "body '" + f.body + "' is driven by two fingertips");
      if (!sources.insert(index).second) k.Error(t, "two fingertips follow the same tracked finger or body");
      // the body: a free body of this scene
      if (!f.body.empty()) {
        const SceneBody* b = nullptr;
        for (const SceneBody& sb : s->bodies)
          if (sb.spec.name == f.body) b = &sb;
        if (!b)
          k.Error(k.Raw("body"), "tracked fingertip '" + f.name + "' names an unknown body '" + f.body + "'");
        else if (b->spec.motion != EMotion::Free || b->has_drive)
          k.Error(k.Raw("body"), "the body '" + f.body + "' of a tracked fingertip must be a free body without a drive");
      }
      k.Finish();
      c.fingertips.push_back(f);
    }
  }
  m.Finish();
}

bool ResolveTracker(World& w, tracking::TrackerConfig* c, std::string* error) {
  for (tracking::FingertipMap& f : c->fingertips) {
    f.body_index = -1;
    for (size_t i = 0; i < w.bodies.size(); ++i)
      if (w.bodies[i].name == f.body) f.body_index = static_cast<int>(i);
    if (f.body_index < 0) {
      *error = "tracked fingertip '" + f.name + "': no body '" + f.body + "'";
      return false;
    }
  }
  return true;
}

}  // namespace gs::app
