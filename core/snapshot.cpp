// Snapshots for drawing: TakeSnapshot copies, ExpandSurfaces applies eq. 8.
#include "core/snapshot.h"

#include "core/world.h"

namespace gs {

std::shared_ptr<const SnapshotRig> BuildSnapshotRig(const World& w) {
  auto rig = std::make_shared<SnapshotRig>();
  rig->bodies.resize(w.bodies.size());
  constexpr int K = SurfaceRig::kWeights;
  for (size_t b = 0; b < w.bodies.size(); ++b) {
    const Body& body = w.bodies[b];
    SurfaceRig& r = rig->bodies[b];
    r.name = body.name;
    r.is_plane = body.geometry.is_plane;
    r.finger = body.finger;
    r.fixed = body.motion == EMotion::Fixed;
    r.spacing = body.geometry.spacing;
    r.shape = body.geometry.shape;
    if (r.is_plane) continue;
    r.rest_p = body.geometry.cloud.positions;
    r.rest_n = body.geometry.cloud.normals;
    const DeformableModel& d = body.deform;
    const std::vector<int>& leaf_of = body.geometry.tree.point_leaf();
    r.deformable = d.enabled() && leaf_of.size() == r.rest_p.size();
    if (!r.deformable) continue;
    const size_t n = r.rest_p.size();
    r.idx.assign(n * K, 0);
    r.w.assign(n * K, 0.0);
    r.grad.assign(n * K, Vec3::Zero());
    const double h2 = d.spacing() * d.spacing();
    const std::vector<Vec3>& cp = body.geometry.tree.control_points();
    for (size_t i = 0; i < n; ++i) {
      int* idx = &r.idx[i * K];
      double* wt = &r.w[i * K];
      const int count = d.Interpolate(r.rest_p[i], leaf_of[i], idx, wt, K);
      Vec3 cbar = Vec3::Zero();
      for (int k = 0; k < count; ++k) cbar += wt[k] * cp[idx[k]];
      for (int k = 0; k < count; ++k)
        r.grad[i * K + k] = h2 > 0 ? Vec3((2.0 / h2) * wt[k] * (cp[idx[k]] - cbar)) : Vec3::Zero();
    }
  }
  return rig;
}

void TakeSnapshot(const World& w, WorldSnapshot* out) {
  out->bodies.resize(w.bodies.size());
  for (size_t b = 0; b < w.bodies.size(); ++b) {
    const Body& body = w.bodies[b];
    BodyState& s = out->bodies[b];
    s.pose = body.pose;
    s.moved = false;
    if (!body.deform.enabled()) {
      s.u.clear();
      continue;
    }
    s.u.assign(body.u.begin(), body.u.end());
    for (const Vec3& u : body.u)
      if (u.x() != 0.0 || u.y() != 0.0 || u.z() != 0.0) {
        s.moved = true;
        break;
      }
  }
  out->contacts.resize(w.rows.size());
  for (size_t c = 0; c < w.rows.size(); ++c) {
    const ContactRow& row = w.rows[c];
    ContactState& s = out->contacts[c];
    s.point = row.world_point;
    s.normal = row.contact.normal;
    s.force = row.frame.transpose() * row.r;
    s.body[0] = row.contact.body[0];
    s.body[1] = row.contact.body[1];
    const double rn = row.r.x(), rt = row.r.tail<2>().norm();
    s.slip = rn > 0.0 && row.mu > 0.0 && rt >= (1.0 - 1e-3) * row.mu * rn;
  }
  out->fingers.resize(w.hand.fingers.size());
  for (size_t f = 0; f < w.hand.fingers.size(); ++f) {
    const Finger& fi = w.hand.fingers[f];
    const FingerKinematics k = FingerForward(fi.model, w.hand.pose, fi.q);
    FingerState& s = out->fingers[f];
    s.points[0] = k.origin[1];
    s.points[1] = k.origin[2];
    s.points[2] = k.origin[3];
    // the distal link runs along the fingertip frame's z axis (finger.h)
    s.points[3] = k.origin[3] + fi.model.link_lengths[2] * k.tip.R.col(2);
    s.points[4] = fi.body >= 0 ? w.bodies[fi.body].pose.t : k.tip.t;
    s.body = fi.body;
  }
  HudState& h = out->hud;
  h.time = w.time;
  h.step = w.step_count;
  h.step_ms = 1e3 * w.profile.total;
  h.contacts = static_cast<int>(w.rows.size());
  h.iterations = w.profile.iterations;
  h.residual = w.profile.residual;
  h.converged = w.profile.converged;
}

void ExpandSurfaces(const SnapshotRig& rig, const WorldSnapshot& s, std::vector<SurfaceFrame>* out) {
  constexpr int K = SurfaceRig::kWeights;
  out->resize(rig.bodies.size());
  for (size_t b = 0; b < rig.bodies.size() && b < s.bodies.size(); ++b) {
    const SurfaceRig& r = rig.bodies[b];
    const BodyState& st = s.bodies[b];
    SurfaceFrame& f = (*out)[b];
    const size_t n = r.rest_p.size();
    f.positions.resize(n);
    f.normals.resize(n);
    const Pose& pose = st.pose;
    const bool deformed = r.deformable && st.moved && !st.u.empty();
    if (!deformed) {
      for (size_t i = 0; i < n; ++i) {
        f.positions[i] = pose.Apply(r.rest_p[i]);
        f.normals[i] = pose.Rotate(r.rest_n[i]);
      }
      continue;
    }
    const int nu = static_cast<int>(st.u.size());
    for (size_t i = 0; i < n; ++i) {
      Vec3 disp = Vec3::Zero();
      Mat3 grad = Mat3::Zero();
      for (int k = 0; k < K; ++k) {
        const double wk = r.w[i * K + k];
        if (wk == 0.0) continue;
        const int j = r.idx[i * K + k];
        if (j < 0 || j >= nu) continue;
        const Vec3& u = st.u[j];
        disp += wk * u;
        grad.noalias() += u * r.grad[i * K + k].transpose();
      }
      // n' ~ (I + G)^-T n; the cofactor form avoids a division by det
      const Mat3 F = Mat3::Identity() + grad;
      Vec3 nn;
      const Vec3 c0 = F.col(1).cross(F.col(2)), c1 = F.col(2).cross(F.col(0)), c2 = F.col(0).cross(F.col(1));
      // cofactor matrix cof(F) has columns c0, c1, c2 and cof(F) = det(F) F^-T
      nn = c0 * r.rest_n[i].x() + c1 * r.rest_n[i].y() + c2 * r.rest_n[i].z();
      const double len = nn.norm();
      nn = len > 1e-12 && std::isfinite(len) ? Vec3(nn / len) : r.rest_n[i];
      f.positions[i] = pose.Apply(r.rest_p[i] + disp);
      f.normals[i] = pose.Rotate(nn);
    }
  }
}

}  // namespace gs
