#include "scene/scene_file.h"

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "scene/mesh_import.h"
#include "scene/scene_checks.h"
#include "core/well_posed.h"

#include <Eigen/Eigenvalues>

namespace gs::app {
namespace {

constexpr double kInf = 1e300;
constexpr double kBig = 1e6;  // generous bound on lengths (m) and forces
// kernel_bandwidth_m in mean point spacings (RecommendedMlsParams: 1.5)
constexpr double kMinBandwidthSpacings = 0.5, kMaxBandwidthSpacings = 10.0;

Mat3 RotationDeg(const Vec3& deg) {
  const Vec3 r = deg * (M_PI / 180.0);
  return (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

// where a key of a mapping was given, or the mapping itself when it was not
SceneError Site(const std::string& file, const YAML::Node& map, const char* key) {
  const YAML::Node& cmap = map;
  const YAML::Node n = cmap.IsMap() ? cmap[key] : YAML::Node();
  return ErrorAt(file, n ? n : map, "");
}

// a list of exactly n finite numbers in [lo, hi]
bool ReadList(MapReader& m, const YAML::Node& n, const std::string& key, int count, double lo, double hi, double* out) {
  if (!n.IsSequence() || static_cast<int>(n.size()) != count) {
    m.Error(n, "'" + key + "' must be a list of " + std::to_string(count) + " numbers");
    return false;
  }
  for (int i = 0; i < count; ++i) {
    double v;
    if (!n[i].IsScalar() || !ParseNumber(n[i].Scalar(), &v) || v < lo || v > hi) {
      std::ostringstream s;
      s << "'" << key << "' item " << i + 1 << " must be a finite number in [" << lo << ", " << hi << "]";
      m.Error(n[i], s.str());
      return false;
    }
    out[i] = v;
  }
  return true;
}

void ReadShape(MapReader& parent, const std::string& key, const std::string& dir, SceneBody* body) {
  YAML::Node node = parent.Raw(key);
  if (!node) {
    parent.Error("missing required key '" + key + "'");
    return;
  }
  body->shape_at = ErrorAt(parent.file(), node, "");
  MapReader m(node, parent.file(), key, parent.errors());
  if (!m.ok()) return;
  std::string type;
  m.Choice("type", &type, {"box", "sphere", "ellipsoid", "capsule", "cylinder", "mesh", "plane"}, true);
  ShapeDesc& s = body->spec.shape;
  if (type == "box") {
    s.type = EShape::Box;
    Vec3 size;
    if (m.Vector3("size_m", &size, 1e-9, kBig, true)) s.half_extents = 0.5 * size;
  } else if (type == "sphere") {
    s.type = EShape::Sphere;
    m.Number("radius_m", &s.radius, 0, kBig, true, true);
  } else if (type == "ellipsoid") {
    s.type = EShape::Ellipsoid;
    m.Vector3("semi_axes_m", &s.semi_axes, 1e-9, kBig, true);
  } else if (type == "capsule" || type == "cylinder") {
    s.type = type == "capsule" ? EShape::Capsule : EShape::Cylinder;
    m.Number("radius_m", &s.radius, 0, kBig, true, true);
    double len = 0;
    if (m.Number(type == "capsule" ? "length_m" : "height_m", &len, 0, kBig, true, type == "cylinder"))
      s.half_length = 0.5 * len;
  } else if (type == "mesh") {
    s.type = EShape::Mesh;
    std::string file;
    if (m.Text("file", &file, true)) {
      std::filesystem::path p(file);
      if (p.is_relative()) p = std::filesystem::path(dir) / p;
      body->mesh_file = p.string();
      body->shape_at = Site(parent.file(), node, "file");
      std::error_code ec;
      if (!std::filesystem::exists(p, ec)) m.Error(m.Raw("file"), "mesh file '" + p.string() + "' does not exist");
    }
    m.Number("scale", &body->mesh_scale, 0, kBig, false, true);
  } else if (type == "plane") {
    body->spec.is_plane = true;
  }
  m.Finish();
}


void ReadGeometry(MapReader& m, SceneBody* b) {
  if (b->spec.is_plane) return;
  int64_t points = 0, cps = 0, seed = 1;
  m.Integer("points", &points, 4, 2000000, true);
  m.Integer("control_points", &cps, 1, 2000000, true);
  m.Integer("seed", &seed, 0, INT64_MAX, false);
  if (m.Number("kernel_bandwidth_m", &b->spec.geometry.bandwidth, 0, kBig, false))
    b->bandwidth_at = ErrorAt(m.file(), m.Raw("kernel_bandwidth_m"), "");
  b->spec.geometry.points = static_cast<int>(points);
  b->spec.geometry.control_points = static_cast<int>(cps);
  b->spec.geometry.seed = static_cast<uint64_t>(seed);
  if (points > 0 && cps > points) m.Error(m.Raw("control_points"), "'control_points' cannot exceed 'points'");
}

// `inertia_kg_m2`: the principal moments [Ixx, Iyy, Izz] in the body frame, or the
// full tensor [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]; it must be a rigid body's inertia:
// symmetric positive definite, each principal moment at most the sum of the others
void ReadInertia(MapReader& m, const YAML::Node& n, BodySpec& s) {
  const int count = n.IsSequence() ? static_cast<int>(n.size()) : 0;
  if (count != 3 && count != 6) {
    m.Error(n, "'inertia_kg_m2' must be a list of 3 principal moments [Ixx, Iyy, Izz] or 6 components "
               "[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] (kg m^2, body frame)");
    return;
  }
  double v[6] = {0, 0, 0, 0, 0, 0};
  if (!ReadList(m, n, "inertia_kg_m2", count, -kBig, kBig, v)) return;
  Mat3 I;
  I << v[0], v[3], v[4], v[3], v[1], v[5], v[4], v[5], v[2];
  double lo, hi;
  SymmetricRange(I, &lo, &hi);
  Vec3 p;
  {
    const Eigen::SelfAdjointEigenSolver<Mat3> es(I, Eigen::EigenvaluesOnly);
    p = es.eigenvalues();
  }
  std::ostringstream msg;
  if (!(lo > 1e-13 * hi) || !(hi > 0)) {
    msg << "'inertia_kg_m2' is not positive definite (principal moments " << p[0] << ", " << p[1] << ", " << p[2]
        << " kg m^2): every principal moment must be > 0";
    m.Error(n, msg.str());
    return;
  }
  if (p[2] > (p[0] + p[1]) * (1.0 + 1e-9)) {
    msg << "'inertia_kg_m2' is not a rigid body's inertia: the largest principal moment " << p[2]
        << " exceeds the sum of the other two (" << p[0] << " + " << p[1] << ")";
    m.Error(n, msg.str());
    return;
  }
  if (s.motion != EMotion::Free || s.dynamics != EDynamics::Inertial) {
    m.Error(n, "'inertia_kg_m2' is only for free inertial bodies (motion: free, dynamics: inertial)");
    return;
  }
  s.inertia = I;
}

void ReadBody(const YAML::Node& node, const std::string& file, const std::string& dir, double dt, SceneBody* b,
              std::vector<SceneError>* errors) {
  MapReader m(node, file, "a body", errors);
  if (!m.ok()) return;
  b->at = ErrorAt(file, node, "");
  b->position_at = Site(file, node, "position_m");
  BodySpec& s = b->spec;
  m.Text("name", &s.name, true);
  ReadShape(m, "shape", dir, b);
  ReadGeometry(m, b);
  Vec3 pos = Vec3::Zero(), rot = Vec3::Zero();
  m.Vector3("position_m", &pos, -kBig, kBig, false);
  m.Vector3("rotation_deg", &rot, -1e4, 1e4, false);
  s.pose = Pose{RotationDeg(rot), pos};
  m.Vector3("velocity_m_s", &s.velocity, -kBig, kBig, false);
  m.Vector3("angular_velocity_rad_s", &s.angular_velocity, -kBig, kBig, false);
  std::string motion = "free", dynamics = "inertial";
  m.Choice("motion", &motion, {"free", "fixed", "kinematic"}, false);
  m.Choice("dynamics", &dynamics, {"inertial", "quasi_static"}, false);
  s.motion = motion == "free" ? EMotion::Free : (motion == "fixed" ? EMotion::Fixed : EMotion::Kinematic);
  s.dynamics = dynamics == "inertial" ? EDynamics::Inertial : EDynamics::QuasiStatic;
  m.Number("mass_kg", &s.mass, 0, kBig, s.motion == EMotion::Free && !s.is_plane, true);
  if (YAML::Node dn = m.Raw("damping")) {
    MapReader d(dn, file, "damping", errors);
    d.Number("linear_N_s_m", &s.linear_damping, 0, kInf, false);
    d.Number("angular_N_m_s_rad", &s.angular_damping, 0, kInf, false);
    d.Finish();
  }
  ReadDeformation(m, &s.deformation);
  bool contact_points = true;
  m.Flag("contact_points", &contact_points, false);
  s.emits_contacts = contact_points;
  if (YAML::Node dn = m.Raw("drive")) {
    b->has_drive = true;
    s.drive.enabled = true;
    MapReader d(dn, file, "drive", errors);
    d.Vector3("stiffness_N_m", &s.drive.stiffness, 0, kInf, false);
    d.Vector3("damping_N_s_m", &s.drive.damping, 0, kInf, false);
    d.Vector3("angular_stiffness_N_m_rad", &s.drive.angular_stiffness, 0, kInf, false);
    d.Vector3("angular_damping_N_m_s_rad", &s.drive.angular_damping, 0, kInf, false);
    d.Vector3("force_N", &s.drive.force, -kBig, kBig, false);
    d.Number("max_force_N", &s.drive.max_force, 0, kInf, false, true);
    d.Finish();
    s.drive.target = s.pose;
  }
  if (YAML::Node in = m.Raw("inertia_kg_m2")) ReadInertia(m, in, s);
  // ill-posed combinations
  if (s.is_plane && s.motion != EMotion::Fixed) m.Error("a plane must have 'motion: fixed'");
  if (b->has_drive && s.motion != EMotion::Free) m.Error("'drive' is only for free bodies");
  if (s.motion == EMotion::Free && s.dynamics == EDynamics::QuasiStatic) {
    // A = B/dt + K + D/dt must be positive definite: on every axis damping or a drive gain
    const Drive& d = s.drive;
    for (int i = 0; i < 3; ++i) {
      const bool lin = s.linear_damping > 0 || (d.enabled && (d.stiffness[i] > 0 || d.damping[i] > 0));
      const bool ang = s.angular_damping > 0 || (d.enabled && (d.angular_stiffness[i] > 0 || d.angular_damping[i] > 0));
      if (!lin || !ang) {
        m.Error(m.Raw("dynamics"), std::string("a quasi_static body needs positive damping (damping: linear_N_s_m and "
                            "angular_N_m_s_rad), or drive gains on every axis: B is its only mobility, and its ") +
                (lin ? "rotation" : "translation") + " about axis " + "xyz"[i] + " has none");
        break;
      }
    }
  }
  (void)dt;
  m.Finish();
}

void ReadFinger(const YAML::Node& node, const std::string& file, const std::string& dir, SceneFinger* f,
                std::vector<SceneError>* errors) {
  MapReader m(node, file, "a finger", errors);
  if (!m.ok()) return;
  m.Text("name", &f->name, true);
  Vec3 pos = Vec3::Zero(), rot = Vec3::Zero();
  m.Vector3("base_position_m", &pos, -kBig, kBig, true);
  m.Vector3("base_rotation_deg", &rot, -1e4, 1e4, false);
  f->model.base = Pose{RotationDeg(rot), pos};
  if (YAML::Node n = m.Raw("link_lengths_m")) {
    double l[3];
    if (ReadList(m, n, "link_lengths_m", 3, 1e-6, kBig, l)) f->model.link_lengths = {l[0], l[1], l[2]};
  } else {
    m.Error("missing required key 'link_lengths_m' in a finger");
  }
  f->model.limits = {{{-0.6, 0.6}, {-0.2, 1.6}, {0.0, 1.8}, {0.0, 1.6}}};
  if (YAML::Node n = m.Raw("joint_limits_rad")) {
    if (!n.IsSequence() || n.size() != 4) {
      m.Error(n, "'joint_limits_rad' must be a list of 4 [low, high] pairs");
    } else {
      for (int j = 0; j < 4; ++j) {
        double lh[2];
        if (ReadList(m, n[j], "joint_limits_rad", 2, -2 * M_PI, 2 * M_PI, lh)) {
          if (lh[0] > lh[1]) m.Error(n[j], "a joint limit's low end must not exceed its high end");
          f->model.limits[j] = {lh[0], lh[1]};
        }
      }
    }
  }
  if (YAML::Node n = m.Raw("joints_rad")) {
    double q[4];
    if (ReadList(m, n, "joints_rad", 4, -2 * M_PI, 2 * M_PI, q)) f->joints = Vec4(q[0], q[1], q[2], q[3]);
  }
  if (YAML::Node mn = m.Raw("motor")) {
    MapReader d(mn, file, "motor", errors);
    d.Number("stiffness_N_m_rad", &f->motor_stiffness, 0, kInf, true, true);
    d.Number("damping_N_m_s_rad", &f->motor_damping, 0, kInf, false);
    d.Finish();
  } else {
    m.Error("missing required key 'motor' in a finger");
  }
  m.Number("joint_damping_N_m_s_rad", &f->joint_damping, 0, kInf, false);
  if (YAML::Node tn = m.Raw("fingertip")) {
    MapReader t(tn, file, "fingertip", errors);
    if (t.ok()) {
      f->tip.at = ErrorAt(file, tn, "");
      f->tip.position_at = Site(file, node, "joints_rad");
      f->tip.spec.name = f->name + "_tip";
      f->tip.spec.motion = EMotion::Fingertip;
      ReadShape(t, "shape", dir, &f->tip);
      if (f->tip.spec.is_plane) t.Error("a fingertip cannot be a plane");
      ReadGeometry(t, &f->tip);
      t.Vector3("offset_m", &f->model.tip_offset, -kBig, kBig, false);
      ReadDeformation(t, &f->tip.spec.deformation);
      t.Finish();
    }
  } else {
    m.Error("missing required key 'fingertip' in a finger");
  }
  m.Finish();
}

void ReadKeyframe(const YAML::Node& node, const std::string& file, SceneKeyframe* k, std::vector<SceneError>* errors) {
  MapReader m(node, file, "a script keyframe", errors);
  if (!m.ok()) return;
  m.Number("time_s", &k->time, 0, kInf, true);
  k->has_hand = m.Vector3("hand_position_m", &k->hand_position, -kBig, kBig, false);
  auto per_name = [&](const char* key, auto&& read) {
    YAML::Node n = m.Raw(key);
    if (!n) return;
    if (!n.IsMap()) {
      m.Error(n, std::string("'") + key + "' must map names to values");
      return;
    }
    for (auto it = n.begin(); it != n.end(); ++it) {
      if (!it->first.IsScalar()) {
        m.Error(it->first, std::string("'") + key + "' must map names to values");
        continue;
      }
      read(it->first.Scalar(), it->second);
    }
  };
  per_name("joints_rad", [&](const std::string& name, const YAML::Node& v) {
    double q[4];
    if (ReadList(m, v, "joints_rad", 4, -2 * M_PI, 2 * M_PI, q)) k->joints[name] = Vec4(q[0], q[1], q[2], q[3]);
  });
  per_name("fingertip_targets_m", [&](const std::string& name, const YAML::Node& v) {
    double x[3];
    if (ReadList(m, v, "fingertip_targets_m", 3, -kBig, kBig, x)) k->tip_targets[name] = Vec3(x[0], x[1], x[2]);
    k->tip_target_at[name] = ErrorAt(file, v, "");
  });
  per_name("body_targets", [&](const std::string& name, const YAML::Node& v) {
    MapReader b(v, file, "a body target", errors);
    Vec3 pos = Vec3::Zero(), rot = Vec3::Zero();
    b.Vector3("position_m", &pos, -kBig, kBig, true);
    b.Vector3("rotation_deg", &rot, -1e4, 1e4, false);
    b.Finish();
    k->body_targets[name] = Pose{RotationDeg(rot), pos};
  });
  for (const auto& [name, q] : k->joints)
    if (k->tip_targets.count(name)) m.Error("finger '" + name + "' has both joints_rad and fingertip_targets_m in one keyframe");
  m.Finish();
}

bool Parse(const YAML::Node& root, const std::string& file, Scene* s, std::vector<SceneError>* errors) {
  const std::string dir = std::filesystem::path(file).parent_path().string();
  MapReader m(root, file, "the scene", errors);
  if (!m.ok()) return false;
  s->file = file;
  s->timestep_at = Site(file, root, "timestep_s");
  m.Text("scene", &s->name, true);
  m.Text("description", &s->description, false);
  m.Number("timestep_s", &s->params.dt, 0, 0.1, true, true);
  m.Number("duration_s", &s->duration, 0, 1e7, true, true);
  m.Vector3("gravity_m_s2", &s->params.gravity, -1e4, 1e4, false);
  if (YAML::Node n = m.Raw("solver")) {
    MapReader d(n, file, "solver", errors);
    int64_t it = s->params.solver.max_iterations;
    d.Number("tolerance", &s->params.solver.tolerance, 0, 1, false, true, true);
    d.Integer("max_iterations", &it, 1, 100000, false);
    d.Number("over_relaxation", &s->params.solver.over_relaxation, 0, 2, false, true, true);
    int64_t depth = s->params.solver.anderson_depth;
    d.Integer("anderson_depth", &depth, 0, kAndersonMaxDepth, false);
    std::string measure = s->params.solver.measure == EStopMeasure::Siconos ? "siconos" : "scaled";
    d.Choice("stop_measure", &measure, {"scaled", "siconos"}, false);
    s->params.solver.measure = measure == "siconos" ? EStopMeasure::Siconos : EStopMeasure::Scaled;
    d.Finish();
    s->params.solver.max_iterations = static_cast<int>(it);
    s->params.solver.anderson_depth = static_cast<int>(depth);
  }
  if (YAML::Node n = m.Raw("collision")) {
    MapReader d(n, file, "collision", errors);
    int64_t level = s->params.refit_stop_level;
    d.Number("contact_threshold_m", &s->params.collision.contact_threshold, 0, 1, false);
    d.Integer("refit_stop_level", &level, 0, 64, false);
    int64_t cap = s->params.max_contacts;
    d.Integer("max_contacts", &cap, 1, 10000000, false);
    d.Finish();
    s->params.refit_stop_level = static_cast<int>(level);
    s->params.max_contacts = static_cast<int>(cap);
  }
  if (YAML::Node n = m.Raw("sleep")) {
    // bodies at rest skip collision detection (core SleepParams, docs/skip.md)
    MapReader d(n, file, "sleep", errors);
    SleepParams& sp = s->params.sleep;
    d.Flag("enabled", &sp.enabled, false);
    d.Number("linear_velocity_m_s", &sp.linear_velocity, 0, 1e3, false);
    d.Number("angular_velocity_rad_s", &sp.angular_velocity, 0, 1e3, false);
    d.Number("time_s", &sp.time, 0, 1e6, false);
    d.Number("max_drift_m", &sp.max_drift, 0, 1, false);
    d.Finish();
  }
  if (YAML::Node n = m.Raw("friction")) {
    MapReader d(n, file, "friction", errors);
    d.Number("default", &s->params.default_friction, 0, 1e3, false);
    if (YAML::Node pairs = d.Raw("pairs")) {
      if (!pairs.IsSequence()) {
        d.Error(pairs, "'pairs' must be a list of {a, b, mu}");
      } else {
        for (const YAML::Node& p : pairs) {
          MapReader pr(p, file, "a friction pair", errors);
          Scene::Pair pair{"", "", 0.0};
          pr.Text("a", &pair.a, true);
          pr.Text("b", &pair.b, true);
          pr.Number("mu", &pair.mu, 0, 1e3, true);
          pr.Finish();
          s->friction_pairs.push_back(pair);
        }
      }
    }
    d.Finish();
  }
  if (YAML::Node n = m.Raw("bodies")) {
    if (!n.IsSequence() || n.size() == 0) {
      m.Error(n, "'bodies' must be a non-empty list");
    } else {
      for (const YAML::Node& b : n) {
        SceneBody body;
        ReadBody(b, file, dir, s->params.dt, &body, errors);
        s->bodies.push_back(body);
      }
    }
  } else {
    m.Error("missing required key 'bodies'");
  }
  if (YAML::Node n = m.Raw("hand"); n && n.IsMap() && static_cast<const YAML::Node&>(n)["model"]) {
    ReadTrackedHand(n, file, s, errors);
  } else if (n) {
    MapReader h(n, file, "hand", errors);
    Vec3 pos = Vec3::Zero(), rot = Vec3::Zero();
    h.Vector3("position_m", &pos, -kBig, kBig, false);
    h.Vector3("rotation_deg", &rot, -1e4, 1e4, false);
    s->hand_pose = Pose{RotationDeg(rot), pos};
    if (YAML::Node fs = h.Raw("fingers")) {
      if (!fs.IsSequence() || fs.size() < 1 || fs.size() > 5) {
        h.Error(fs, "'fingers' must be a list of 1 to 5 fingers");
      } else {
        for (const YAML::Node& f : fs) {
          SceneFinger finger;
          ReadFinger(f, file, dir, &finger, errors);
          s->fingers.push_back(finger);
        }
      }
    }
    h.Finish();
  }
  if (YAML::Node n = m.Raw("script")) {
    if (!n.IsSequence()) {
      m.Error(n, "'script' must be a list of keyframes");
    } else {
      for (const YAML::Node& k : n) {
        SceneKeyframe key;
        ReadKeyframe(k, file, &key, errors);
        if (!s->script.empty() && !(key.time > s->script.back().time))
          errors->push_back(ErrorAt(file, k, "script times must increase strictly"));
        if (key.time > s->duration) errors->push_back(ErrorAt(file, k, "a script keyframe lies after duration_s"));
        s->script.push_back(key);
      }
    }
  }
  if (YAML::Node n = m.Raw("tracker")) ReadTrackerSection(n, file, s, errors);
  if (s->tracked_hand.enabled) AddTrackedHandTargets(s, errors);
  if (YAML::Node n = m.Raw("camera")) ReadCameraSection(n, file, s, errors);
  m.Finish();

  // names: unique, and every reference resolves
  std::set<std::string> bodies, fingers;
  for (const SceneBody& b : s->bodies)
    if (!bodies.insert(b.spec.name).second) errors->push_back({file, 0, 0, "duplicate body name '" + b.spec.name + "'"});
  for (const SceneFinger& f : s->fingers) {
    if (!fingers.insert(f.name).second) errors->push_back({file, 0, 0, "duplicate finger name '" + f.name + "'"});
    if (!bodies.insert(f.tip.spec.name).second)
      errors->push_back({file, 0, 0, "body name '" + f.tip.spec.name + "' clashes with a fingertip's name"});
  }
  for (const Scene::Pair& p : s->friction_pairs)
    for (const std::string& n : {p.a, p.b})
      if (!bodies.count(n)) errors->push_back({file, 0, 0, "friction pair names an unknown body '" + n + "'"});
  for (const SceneKeyframe& k : s->script) {
    for (const auto& [n, q] : k.joints)
      if (!fingers.count(n)) errors->push_back({file, 0, 0, "script names an unknown finger '" + n + "'"});
    for (const auto& [n, q] : k.tip_targets)
      if (!fingers.count(n)) errors->push_back({file, 0, 0, "script names an unknown finger '" + n + "'"});
    for (const auto& target : k.body_targets) {
      const std::string& n = target.first;  // a plain name: clang cannot capture structured bindings in C++17
      auto it = std::find_if(s->bodies.begin(), s->bodies.end(), [&](const SceneBody& b) { return b.spec.name == n; });
      if (it == s->bodies.end())
        errors->push_back({file, 0, 0, "script names an unknown body '" + n + "'"});
      else if (!(it->has_drive || it->spec.motion == EMotion::Kinematic))
        errors->push_back({file, 0, 0, "script moves body '" + n + "', which has neither a drive nor motion: kinematic"});
    }
  }
  return errors->empty();
}

}  // namespace

void ReadDeformation(MapReader& parent, DeformationParams* d) {
  YAML::Node node = parent.Raw("deformation");
  if (!node) return;
  MapReader m(node, parent.file(), "deformation", parent.errors());
  if (!m.ok()) return;
  std::string model = "rigid";
  m.Choice("model", &model, {"rigid", "gaussian", "boussinesq"}, true);
  if (model == "rigid") {
    // over a default that deforms (the tracked hand's skin), not left to it
    d->model = EDeformation::Rigid;
  } else if (model == "gaussian") {
    d->model = EDeformation::Gaussian;
    m.Number("stiffness_N_m", &d->stiffness, 0, kInf, true, true);
    m.Number("damping_N_s_m", &d->damping, 0, kInf, false);
    m.Number("influence_radius_m", &d->influence_radius, 0, kBig, true, true);
  } else if (model == "boussinesq") {
    d->model = EDeformation::Boussinesq;
    m.Number("young_modulus_Pa", &d->young_modulus, 0, kInf, true, true);
    m.Number("poisson_ratio", &d->poisson_ratio, 0, 0.5, true, false, true);
    m.Number("damping_N_s_m", &d->damping, 0, kInf, false);
    m.Number("influence_radius_m", &d->influence_radius, 0, kBig, false, true);
  }
  m.Finish();
}

bool LoadSceneFromString(const std::string& text, const std::string& virtual_path, Scene* out,
                         std::vector<SceneError>* errors) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    SceneError err;
    err.file = virtual_path;
    err.line = e.mark.line + 1;
    err.column = e.mark.column + 1;
    err.message = "YAML syntax error: " + e.msg;
    errors->push_back(err);
    return false;
  } catch (const std::exception& e) {
    errors->push_back({virtual_path, 0, 0, std::string("cannot parse: ") + e.what()});
    return false;
  }
  try {
    return Parse(root, virtual_path, out, errors);
  } catch (const std::exception& e) {
    errors->push_back({virtual_path, 0, 0, std::string("invalid scene: ") + e.what()});
    return false;
  }
}

bool LoadScene(const std::string& path, Scene* out, std::vector<SceneError>* errors) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) {
    errors->push_back({path, 0, 0, "cannot read the scene file: " + ec.message()});
    return false;
  }
  if (size > 16u * 1024 * 1024) {
    errors->push_back({path, 0, 0, "the scene file is larger than 16 MiB"});
    return false;
  }
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  if (!f) {
    errors->push_back({path, 0, 0, "cannot read the scene file"});
    return false;
  }
  return LoadSceneFromString(ss.str(), path, out, errors);
}

namespace {

SceneError With(SceneError at, const std::string& message) {
  at.message = message;
  return at;
}

// the scene body of each world body (bodies, then fingertips)
std::vector<const SceneBody*> SceneBodies(const Scene& scene) {
  std::vector<const SceneBody*> all;
  for (const SceneBody& b : scene.bodies) all.push_back(&b);
  for (const SceneFinger& f : scene.fingers) all.push_back(&f.tip);
  return all;
}

int AddSceneBody(World& w, const SceneBody& b, std::vector<SceneError>* errors) {
  BodySpec spec = b.spec;
  TriangleMesh mesh;
  if (b.spec.shape.type == EShape::Mesh && !b.spec.is_plane) {
    std::string err;
    if (!ImportMesh(b.mesh_file, b.mesh_scale, &mesh, &err)) {
      errors->push_back(With(b.shape_at, "body '" + b.spec.name + "': " + err));
      return -1;
    }
    spec.mesh = &mesh;
  }
  EGeometryError ge;
  const int index = AddBody(w, spec, &ge);
  if (index < 0) errors->push_back(With(b.shape_at, "body '" + b.spec.name + "': " + ToString(ge)));
  return index;
}

// every body and finger; false when a body could not be built
bool AddBodiesAndFingers(const Scene& scene, World& w, std::vector<SceneError>* errors) {
  bool ok = true;
  for (const SceneBody& b : scene.bodies) ok &= AddSceneBody(w, b, errors) >= 0;
  w.hand.pose = scene.hand_pose;
  for (const SceneFinger& sf : scene.fingers) {
    const int tip = AddSceneBody(w, sf.tip, errors);
    ok &= tip >= 0;
    Finger f;
    f.name = sf.name;
    f.model = sf.model;
    f.q = f.q_target = ClampJoints(sf.model, sf.joints);
    f.motor_stiffness = sf.motor_stiffness;
    f.motor_damping = sf.motor_damping;
    f.joint_damping = sf.joint_damping;
    f.body = tip;
    w.hand.fingers.push_back(f);
  }
  if (ok) AddTrackedFingers(scene, w);
  return ok;
}

// the MLS bandwidth against the sampled spacing
void CheckBandwidths(const std::vector<const SceneBody*>& scene_bodies, const World& w,
                     std::vector<SceneError>* errors) {
  for (size_t i = 0; i < scene_bodies.size(); ++i) {
    const SceneBody& sb = *scene_bodies[i];
    const Body& b = w.bodies[i];
    if (sb.spec.is_plane || !(sb.spec.geometry.bandwidth > 0)) continue;
    const double ratio = sb.spec.geometry.bandwidth / b.geometry.spacing;
    if (ratio >= kMinBandwidthSpacings && ratio <= kMaxBandwidthSpacings) continue;
    std::ostringstream s;
    s << "body '" << b.name << "': 'kernel_bandwidth_m' = " << sb.spec.geometry.bandwidth << " m is " << ratio
      << " times the mean point spacing (" << b.geometry.spacing << " m); expected " << kMinBandwidthSpacings << " to "
      << kMaxBandwidthSpacings
      << " times it: narrower, the MLS fits find too few points and contacts are lost; wider, the surface is "
         "smoothed away and every leaf overlaps its neighbours. Use kernel_bandwidth_m = "
      << 1.5 * b.geometry.spacing << " (1.5 spacings, the default when it is left out)";
    errors->push_back(With(sb.bandwidth_at, s.str()));
  }
}

// the time step and starting overlaps (scene/scene_checks.h), and the core's check of
// every parameter the step divides by or inverts (a backstop: the parser checks them)
void CheckWellPosed(const Scene& scene, const std::vector<const SceneBody*>& scene_bodies, const World& w,
                    std::vector<SceneError>* errors) {
  for (const IllPosed& p : FindIllPosed(w)) {
    const SceneError& at = p.site == IllPosed::ESite::TimeStep  ? scene.timestep_at
                           : p.site == IllPosed::ESite::Sampling ? scene_bodies[p.body]->at
                                                                 : scene_bodies[p.other]->position_at;
    errors->push_back(With(at, p.message));
  }
  const std::string why = WellPosedError(w);
  if (why.empty()) return;
  SceneError at{scene.file, 0, 0, ""};
  for (const SceneBody* sb : scene_bodies)
    if (why.rfind("body '" + sb->spec.name + "'", 0) == 0) at = sb->at;
  errors->push_back(With(at, "the scene is ill-posed: " + why));
}

// fingertip targets become joint targets by inverse kinematics, each solved from the
// previous keyframe's joints of that finger; an unreachable target is an error
void BuildScript(const Scene& scene, World& w, ScriptPlayer* script, std::vector<SceneError>* errors) {
  auto body_index = [&](const std::string& name) {
    for (size_t i = 0; i < w.bodies.size(); ++i)
      if (w.bodies[i].name == name) return static_cast<int>(i);
    return -1;
  };
  std::vector<Vec4> last(w.hand.fingers.size());
  for (size_t f = 0; f < w.hand.fingers.size(); ++f) last[f] = w.hand.fingers[f].q;
  for (const SceneKeyframe& k : scene.script) {
    if (k.has_hand) script->SetHandPosition(k.time, k.hand_position);
    for (size_t f = 0; f < w.hand.fingers.size(); ++f) {
      const Finger& fg = w.hand.fingers[f];
      if (auto it = k.joints.find(fg.name); it != k.joints.end()) {
        last[f] = it->second;
        script->SetFingerJoints(static_cast<int>(f), k.time, it->second);
      } else if (auto jt = k.tip_targets.find(fg.name); jt != k.tip_targets.end()) {
        Vec4 q;
        const double residual = FingerInverse(fg.model, jt->second, last[f], &q);
        if (residual > 1e-3) {
          const Vec3 reach = FingerForward(fg.model, Pose(), q).tip.t;
          std::ostringstream s;
          s << "script at " << k.time << " s: finger '" << fg.name << "' cannot reach its fingertip target ("
            << residual * 1e3 << " mm short within its joint limits). Use a target it reaches, such as [" << reach.x()
            << ", " << reach.y() << ", " << reach.z() << "] m (where the inverse kinematics stopped), or move the hand";
          errors->push_back(With(k.tip_target_at.at(fg.name), s.str()));
        }
        last[f] = q;
        script->SetFingerJoints(static_cast<int>(f), k.time, q);
      }
    }
    for (const auto& [name, pose] : k.body_targets) script->SetBodyTarget(body_index(name), k.time, pose);
  }
}

}  // namespace

bool BuildScene(const Scene& scene, BuiltScene* out, std::vector<SceneError>* errors) {
  const size_t errors_before = errors->size();
  World& w = out->world;
  out->name = scene.name;
  out->duration = scene.duration;
  w.params = scene.params;
  const SceneTrackedHand& th = scene.tracked_hand;
  if (th.sizes_from_tracker && !th.sized) {
    SceneError note = th.sizes_at;
    note.message = "note: 'sizes: tracker' with no tracker session here: the hand has the default sizes (an average "
                   "adult hand); replay and live size it from the tracker";
    out->sizes_note = note.Format();
  }
  if (!AddBodiesAndFingers(scene, w, errors)) return false;
  w.Finalize();
  for (const Scene::Pair& p : scene.friction_pairs) {
    int a = -1, b = -1;
    for (size_t i = 0; i < w.bodies.size(); ++i) {
      if (w.bodies[i].name == p.a) a = static_cast<int>(i);
      if (w.bodies[i].name == p.b) b = static_cast<int>(i);
    }
    w.SetFriction(a, b, p.mu);
  }
  ExcludeHandPairs(scene, w);
  const std::vector<const SceneBody*> scene_bodies = SceneBodies(scene);
  CheckBandwidths(scene_bodies, w, errors);
  CheckWellPosed(scene, scene_bodies, w, errors);
  BuildScript(scene, w, &out->script, errors);
  out->tracked_body = -1;
  for (size_t i = 0; i < w.bodies.size(); ++i)
    if (w.bodies[i].motion == EMotion::Free) {
      out->tracked_body = static_cast<int>(i);
      break;
    }
  out->has_tracker = scene.has_tracker;
  out->tracker = scene.tracker;
  out->has_camera = scene.has_camera;
  out->camera = scene.camera;
  std::string error;
  if (scene.has_tracker && !ResolveTracker(w, &out->tracker, &error)) errors->push_back({scene.file, 0, 0, error});
  if (errors->size() != errors_before) return false;
  // the first keyframe's targets hold from the start
  out->script.Apply(w, 0.0);
  return true;
}

bool BuildScene(const Scene& scene, BuiltScene* out, std::string* error) {
  std::vector<SceneError> errors;
  if (BuildScene(scene, out, &errors)) return true;
  std::string all;
  for (const SceneError& e : errors) all += (all.empty() ? "" : "\n") + e.Format();
  *error = all;
  return false;
}

bool LoadAndBuildScene(const std::string& path, BuiltScene* out, std::string* error) {
  Scene scene;
  std::vector<SceneError> errors;
  if (!LoadScene(path, &scene, &errors)) {
    std::string all;
    for (const SceneError& e : errors) all += (all.empty() ? "" : "\n") + e.Format();
    *error = all;
    return false;
  }
  return BuildScene(scene, out, error);
}

}  // namespace gs::app
