#include "scene/code_scenes.h"

#include <algorithm>
#include <cmath>

#include "core/sampling.h"

namespace gs::app {

BodySpec PlaneSpec(const std::string& name, const Pose& pose) {
  BodySpec s;
  s.name = name;
  s.is_plane = true;
  s.motion = EMotion::Fixed;
  s.pose = pose;
  return s;
}

TriangleMesh HexagonalPrism(double circumradius, double height) {
  TriangleMesh m;
  const double h = 0.5 * height;
  for (int k = 0; k < 6; ++k) {
    const double a = M_PI / 6 + k * M_PI / 3;
    m.vertices.push_back(Vec3(circumradius * std::cos(a), circumradius * std::sin(a), -h));
  }
  for (int k = 0; k < 6; ++k) m.vertices.push_back(Vec3(m.vertices[k].x(), m.vertices[k].y(), h));
  m.vertices.push_back(Vec3(0, 0, -h));  // 12: bottom centre
  m.vertices.push_back(Vec3(0, 0, h));   // 13: top centre
  for (int k = 0; k < 6; ++k) {
    const int a = k, b = (k + 1) % 6;
    m.triangles.push_back(Eigen::Vector3i(a, b, b + 6));
    m.triangles.push_back(Eigen::Vector3i(a, b + 6, a + 6));
    m.triangles.push_back(Eigen::Vector3i(12, b, a));
    m.triangles.push_back(Eigen::Vector3i(13, a + 6, b + 6));
  }
  return m;
}

bool PinchRig::ok() const {
  return table >= 0 && prism >= 0 && tips.size() == 3 && *std::min_element(tips.begin(), tips.end()) >= 0;
}

PinchRig AddPinchRig(World& w, const PinchRigSpec& spec, EGeometryError* error) {
  constexpr double kCircumradius = 0.02, kHeight = 0.06, kTipRadius = 0.008;
  PinchRig rig;
  rig.table = AddBody(w, PlaneSpec("table", Pose{}), error);
  TriangleMesh mesh = HexagonalPrism(kCircumradius, kHeight);
  ValidateAndOrientMesh(&mesh);
  const double apothem = kCircumradius * std::cos(M_PI / 6);
  BodySpec pr;
  pr.name = spec.cylinder ? "cylinder" : "prism";
  pr.mesh = spec.cylinder ? nullptr : &mesh;  // sampled inside AddBody
  pr.shape.type = EShape::Cylinder;  // inertia of the enclosing cylinder
  pr.shape.radius = spec.cylinder ? apothem : 0.0185;
  pr.shape.half_length = 0.5 * kHeight;
  pr.geometry.points = spec.prism_points;
  pr.geometry.control_points = spec.prism_control_points;
  pr.mass = spec.prism_mass;
  pr.pose = Pose::Translation(Vec3(0, 0, 0.5 * kHeight));
  pr.emits_contacts = spec.two_pass;  // one-pass: only the fingertips' points on the faces
  rig.prism = AddBody(w, pr, error);
  for (int k = 0; k < 3; ++k) {
    const double a = k * 2.0 * M_PI / 3.0;
    const Vec3 radial(std::cos(a), std::sin(a), 0);
    BodySpec t;
    t.name = "tip" + std::to_string(k);
    t.shape.type = EShape::Sphere;
    t.shape.radius = kTipRadius;
    t.geometry.points = 2400;
    t.geometry.control_points = 320;
    t.mass = 0.01;
    t.deformation.model = spec.rigid_tips ? EDeformation::Rigid : EDeformation::Gaussian;
    t.deformation.stiffness = 300;
    t.deformation.damping = 0.5;
    t.deformation.influence_radius = 0.0015;
    // drive frame: x toward the prism's axis; pushed along x, stiff across and vertically.
    // The centre sits 0.2 mm inside touching (radius 8 mm), so the squeeze starts in contact.
    const Pose target{Eigen::AngleAxisd(a + M_PI, Vec3::UnitZ()).toRotationMatrix(),
                      radial * (apothem + 0.0078) + Vec3(0, 0, 0.5 * kHeight)};
    t.pose = target;
    t.drive.enabled = true;
    t.drive.stiffness = Vec3(0, 3000, 3000);
    t.drive.damping = Vec3(0.5, 20, 20);
    t.drive.angular_stiffness = Vec3::Constant(0.5);
    t.drive.angular_damping = Vec3::Constant(0.01);
    t.drive.force = Vec3(spec.squeeze_force, 0, 0);
    t.drive.target = target;
    rig.tips.push_back(AddBody(w, t, error));
    rig.tip_start.push_back(target);
  }
  return rig;
}

}  // namespace gs::app
