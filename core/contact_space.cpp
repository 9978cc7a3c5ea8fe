// Contact space (the paper's "LCP construction"): for every contact, its frame
// (n, t1, t2), its free gap and free slip, the rows H = +-frame^T J of its two
// articulations, the eq. 8 interpolation of its points over the control points,
// and the diagonal block W_cc = sum H A^-1 H^T + W_deform,cc (eq. 12). The
// off-diagonal blocks are never formed (the solver goes through the bodies).
// Forces are warm started from the previous step's force of the same contact
// key, re-expressed in the new frame.
#include <algorithm>
#include <chrono>

#include "core/contact_jacobian.h"
#include "core/world.h"

namespace gs {
namespace {

// interpolated displacement of a contact side from per-control-point values
Vec3 SideDisplacement(const ContactSide& s, const std::vector<Vec3>& u) {
  Vec3 d = Vec3::Zero();
  for (int k = 0; k < s.count; ++k) d += s.w[k] * u[s.idx[k]];
  return d;
}

// same eq. 8 interpolation (control points and weights, bitwise)
bool SameWeights(const ContactSide& a, const ContactSide& b) {
  if (a.count != b.count) return false;
  for (int k = 0; k < a.count; ++k)
    if (a.idx[k] != b.idx[k] || a.w[k] != b.w[k]) return false;
  return true;
}

// the side's merged influence sum_k w_k phi(k, m) appended to the world's
// buffers, and its diagonal term sum_i w_i (sum_k w_k phi_ki)
void BuildSideInfluence(World& w, Body& b, ContactSide* side) {
  const int begin = static_cast<int>(w.side_inf_idx.size());
  // the buffers sized once for the longest possible merge (phi zero-filled), written
  // through pointers and cut to the merged length after: no push_back per entry
  int most = 0;
  for (int k = 0; k < side->count; ++k) {
    const int* idx;
    const double* phi;
    most += b.deform.Influence(side->idx[k], &idx, &phi);
  }
  w.side_inf_idx.resize(static_cast<size_t>(begin) + most);
  w.side_inf_phi.resize(static_cast<size_t>(begin) + most, 0.0);
  int* out_idx = w.side_inf_idx.data();
  double* out_phi = w.side_inf_phi.data();
  int* slots = b.inf_slot.data();
  int end = begin;
  for (int k = 0; k < side->count; ++k) {
    const int* idx;
    const double* phi;
    const int m = b.deform.Influence(side->idx[k], &idx, &phi);
    const double wk = side->w[k];
    for (int j = 0; j < m; ++j) {
      int slot = slots[idx[j]];
      if (slot < 0) {
        slot = end++;
        slots[idx[j]] = slot;
        out_idx[slot] = idx[j];
      }
      out_phi[slot] += wk * phi[j];
    }
  }
  double k = 0.0;
  for (int i = 0; i < side->count; ++i) k += side->w[i] * out_phi[slots[side->idx[i]]];
  for (int j = begin; j < end; ++j) slots[out_idx[j]] = -1;
  w.side_inf_idx.resize(end);
  w.side_inf_phi.resize(end);
  side->inf_begin = begin;
  side->inf_count = end - begin;
  side->w_deform = k;
}

// Last step's entry of a contact key, in a list of last step's entries (rows or
// forces). Collision detection gives contacts in the same order step after step
// (each pair's leaves in tree order), so the entry after the last one found is
// tried first; the hash index over the list is built at the first miss of the step
// only. A step whose contacts all persist in order does no hashing at all.
template <class KeyAt>
class PrevLookup {
 public:
  PrevLookup(KeyIndex* index, int size, KeyAt key_at) : index_(index), size_(size), key_at_(key_at) {}
  int Find(uint64_t key) {
    if (next_ < size_ && key_at_(next_) == key) return next_++;
    if (!indexed_) {
      index_->Clear(size_);
      for (int i = 0; i < size_; ++i) index_->Insert(key_at_(i), i);
      indexed_ = true;
    }
    const int found = index_->Find(key);
    if (found >= 0) next_ = found + 1;
    return found;
  }

 private:
  KeyIndex* index_;
  int size_;
  KeyAt key_at_;
  int next_ = 0;
  bool indexed_ = false;
};

// the free displacement's share of the gap and slip, the held-back overlap, the warm start
template <class WarmLookup>
void FinishRow(World& w, ContactRow* row, double gap_def, const Vec3& slip_def, WarmLookup* warm_lookup) {
  const Contact& c = row->contact;
  // normal: position-level gap after free motion (eq. 6); tangents: free slip over the step
  row->q += Vec3(gap_def, row->frame.row(1).dot(slip_def), row->frame.row(2).dot(slip_def));
  // an overlap present at the start of the step is removed at a bounded speed:
  // the solver sees the rest of it as allowed for this step
  if (w.params.max_push_out_speed > 0.0) {
    row->held_back = std::max(0.0, -row->gap_start - w.params.max_push_out_speed * w.params.dt);
    row->q[0] += row->held_back;
  }
  row->r.setZero();
  // warm start: the previous world force of the same key, in the new frame
  const int warm = warm_lookup->Find(c.key);
  if (warm >= 0) {
    row->r = row->frame * w.warm_prev[warm].second;
    ++w.profile.work.warm_started;
  }
}

// The rigid part of contact c's row (row.prev set): its frame, the free slip of its
// material points, the Jacobian rows of its finger sides (into w.side_jacobians from
// `jacobian` on, FingerSides of them) and W_rigid,cc.
void BuildRigidRow(World& w, const Contact& c, ContactRow& row, int jacobian, int* weights_reused) {
  row.contact = c;
  const Vec3 n = c.normal;
  const Vec3 t1 = AnyPerpendicular(n);
  const Vec3 t2 = n.cross(t1);
  Mat3 frame;  // read back below from here, not from the row just written
  frame.row(0) = n;
  frame.row(1) = t1;
  frame.row(2) = t2;
  row.frame = frame;
  Vec3 world_pt[2];
  Vec3 slip = Vec3::Zero();
  double normal_turn = 0.0;  // what the free motion adds to the normal slip at the touching points
  row.w_diag.setZero();
  for (int s = 0; s < 2; ++s) {
    const Body& b = w.bodies[c.body[s]];
    ContactSide& side = row.side[s];
    side.body = c.body[s];
    side.sign = s == 0 ? 1.0 : -1.0;
    world_pt[s] = b.pose.Apply(c.anchor[s]);
    side.articulation = b.articulation;
    side.jacobian = -1;
    side.count = 0;
    side.inf_begin = side.inf_count = 0;
    side.w_deform = 0.0;
    // eq. 8 weights of the contact point over the control points (deformable bodies):
    // the query side's contact point is the control point itself
    if (b.deform.enabled()) {
      if (s == 0) {
        side.count = 1;
        side.idx[0] = c.leaf;
        side.w[0] = 1.0;
        side.weights_at = c.anchor[0];
      } else if (c.surface_leaf >= 0) {
        const ContactSide* ps = row.prev >= 0 ? &w.rows_prev[row.prev].side[1] : nullptr;
        const double tol = w.params.reuse_anchor_tolerance * b.deform.spacing();
        if (ps && ps->body == side.body && ps->count > 0 && w.rows_prev[row.prev].contact.surface_leaf == c.surface_leaf &&
            (c.anchor[1] - ps->weights_at).squaredNorm() <= tol * tol) {
          // the anchor has barely moved: the last step's interpolation (bit for bit when
          // the anchor is unchanged, and then its merged influence is reused below)
          side.count = ps->count;
          std::copy(ps->idx, ps->idx + ps->count, side.idx);
          std::copy(ps->w, ps->w + ps->count, side.w);
          side.weights_at = ps->weights_at;
          ++*weights_reused;
        } else {
          side.count = b.deform.Interpolate(c.anchor[1], c.surface_leaf, side.idx, side.w, ContactSide::kMaxWeights);
          side.weights_at = c.anchor[1];
        }
      }
    }
    // The material point: on a deformable body, the rest anchor displaced by u. The
    // body's rotation turns it where it is, so the Jacobian's lever arm ends there. With
    // the arm to the rest anchor instead, a contact torque that turns a fingertip by
    // dtheta per step moves its squashed contact points by dtheta x R u unseen by the
    // solver (0.2 um per step in the pinch, u = 0.8 mm): a grasp the solver holds in
    // sticking friction creeps. u is the last step's displacement, which this step's
    // stays close to; what is left, dtheta x (u_new - u), vanishes in a steady hold.
    const Vec3 x = side.count > 0 ? Vec3(c.anchor[s] + SideDisplacement(side, b.u)) : c.anchor[s];
    const Vec3 lever_pt = b.pose.Apply(x);
    const Vec3 arm = b.pose.Rotate(c.touch[s]);  // to where the rest surfaces touch (Contact::touch)
    if (b.articulation < 0) {
      // fixed or kinematic: its prescribed motion over the step
      slip += side.sign * (lever_pt - b.pose_prev.Apply(x));
      continue;
    }
    const Articulation& a = w.articulations[b.articulation];
    // Free slip of the material point, linearised where the contact response is (at
    // the free-motion configuration): J dq_free, not the finite difference
    // x(q_free) - x(q_prev). The step ends at q_free + dq with the solver taking that
    // as J (dq_free + dq); the finite difference would add the curvature term
    // 1/2 dq_free^T H dq_free, which does not vanish when the motor's pull (dq_free)
    // and the contact's push (dq) cancel in a steady hold: a finger pressing with
    // 2.6e-3 rad of free motion per step made the paper's box slide 0.8 mm/s in
    // what the solver took for sticking contacts. Linearised, the error is
    // dq_total^T H dq_free, zero when the hold is steady. The gap stays the
    // position-level one from collision detection (its error is not integrated).
    if (a.finger < 0) {
      // a free body: its lever arm, J applied in place (core/contact_jacobian.h)
      const Vec3 lever = lever_pt - b.pose.t;
      const Vec3 spin = arm.cross(n);
      side.lever = lever;
      side.spin = spin;
      slip += side.sign * FreeSideMotion(a.dq_free, lever);
      normal_turn += side.sign * a.dq_free.tail<3>().dot(spin);
      AddFreeSideBlock(a, lever, spin, n, t1, t2, &row.w_diag);
      continue;
    }
    Eigen::Matrix<double, 3, 6> J;
    J.leftCols<4>() = FingerPointJacobian(w.hand.fingers[a.finger].kin, lever_pt, b.finger_link);
    J.rightCols<2>().setZero();
    // the hand's own (prescribed) motion carries the finger
    const Vec3 carried = lever_pt - w.hand.pose_prev.Apply(w.hand.pose.ApplyInverse(lever_pt));
    slip += side.sign * (carried + J * a.dq_free);
    side.jacobian = jacobian++;
    SideJacobian& jac = w.side_jacobians[side.jacobian];
    jac.h = side.sign * frame * J;
    if (!c.touch[s].isZero()) {
      // the normal row at the touching point
      Eigen::Matrix<double, 1, 6> jn = Eigen::Matrix<double, 1, 6>::Zero();
      jn.leftCols<4>() =
          n.transpose() * FingerPointJacobian(w.hand.fingers[a.finger].kin, lever_pt + arm, b.finger_link);
      normal_turn += side.sign * (jn - n.transpose() * J) * a.dq_free;
      jac.h.row(0) = side.sign * jn;
    }
    jac.g = a.a_inv * jac.h.transpose();
    row.w_diag += jac.h * jac.g;
  }
  row.world_point = 0.5 * (world_pt[0] + world_pt[1]);
  row.q = Vec3(c.gap, t1.dot(slip), t2.dot(slip));
  // the free motion's share taken out (the normal's at the touching point); deformation added below
  row.gap_start = c.gap - n.dot(slip) - normal_turn;
  row.held_back = 0.0;
  row.mu = w.Friction(c.body[0], c.body[1]);
}

// finger sides of contact c: the Jacobians its row keeps
int FingerSides(const World& w, const Contact& c) {
  int n = 0;
  for (int s = 0; s < 2; ++s) {
    const Body& b = w.bodies[c.body[s]];
    n += b.articulation >= 0 && w.articulations[b.articulation].finger >= 0 ? 1 : 0;
  }
  return n;
}

}  // namespace

void BuildContactSpace(World& w) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  // the last step's rows and influences become the reuse cache
  std::swap(w.rows, w.rows_prev);
  std::swap(w.side_inf_idx, w.side_inf_idx_prev);
  std::swap(w.side_inf_phi, w.side_inf_phi_prev);
  // the last step's row and force of each contact key (the rows only when reused)
  const auto prev_key = [&w](int i) { return w.rows_prev[i].contact.key; };
  PrevLookup<decltype(prev_key)> prev_rows(&w.rows_prev_index,
                                           w.params.reuse_contact_space ? static_cast<int>(w.rows_prev.size()) : 0,
                                           prev_key);
  const auto warm_key = [&w](int i) { return w.warm_prev[i].first; };
  PrevLookup<decltype(warm_key)> warm_forces(&w.warm_index, static_cast<int>(w.warm_prev.size()), warm_key);
  w.rows.clear();
  w.side_jacobians.clear();
  w.side_inf_idx.clear();
  w.side_inf_phi.clear();
  // rigid part: frames, free slip of the material points, Jacobian rows, W_rigid,cc
  for (const Contact& c : w.contacts.items) {
    ContactRow& row = w.rows.emplace_back();  // reserved by Finalize: a row is ~1.3 kB, built in place
    row.prev = prev_rows.Find(c.key);         // the same contact in the last step, if any
    const int jacobian = static_cast<int>(w.side_jacobians.size());
    w.side_jacobians.resize(jacobian + FingerSides(w, c));  // reserved: two a contact at most
    BuildRigidRow(w, c, row, jacobian, &w.profile.work.weights_reused);
    ++w.profile.work.w_blocks_built;
  }
  // the finger joints near a limit: rows of the same solve (core/joint_limits.cpp)
  BuildJointLimitRows(w);
  const auto t1 = Clock::now();

  // deformable part (skipped for rigid bodies): eq. 8 weights, the side's merged
  // influence sum_k w_k phi(k, m), its diagonal term sum_i w_i (sum_k w_k phi_ki)
  // and the free displacement's share of the gap and slip. Then the warm start.
  for (ContactRow& row : w.rows) {
    const Contact& c = row.contact;
    double gap_def = 0.0;
    Vec3 slip_def = Vec3::Zero();
    const ContactRow* prev = row.prev >= 0 ? &w.rows_prev[row.prev] : nullptr;
    for (int s = 0; s < 2; ++s) {
      Body& b = w.bodies[c.body[s]];
      ContactSide& side = row.side[s];
      if (!b.deform.enabled() || side.count == 0) continue;  // weights set with the rigid part
      ++w.profile.work.w_deform_sides;
      // the control points this side's force reaches are integrated from now on
      for (int k = 0; k < side.count; ++k) b.AddSource(side.idx[k]);
      const int begin = static_cast<int>(w.side_inf_idx.size());
      const ContactSide* ps = prev ? &prev->side[s] : nullptr;
      if (side.count == 1 && side.w[0] == 1.0) {
        // on one control point: its own influence, read in the model (what the merge
        // would copy, bit for bit), and W_deform is its self compliance
        const int* idx;
        const double* phi;
        ++w.profile.work.w_deform_direct;
        side.inf_begin = -1;
        side.inf_count = b.deform.Influence(side.idx[0], &idx, &phi);
        side.w_deform = b.deform.SelfCompliance(side.idx[0]);  // phi[0], packed (no miss per contact)
      } else if (ps && ps->body == side.body && ps->inf_begin >= 0 && SameWeights(*ps, side)) {
        // unchanged since the last step: copy its merged influence and W_deform term
        ++w.profile.work.w_deform_reused;
        const int from = ps->inf_begin;
        w.side_inf_idx.insert(w.side_inf_idx.end(), w.side_inf_idx_prev.begin() + from,
                              w.side_inf_idx_prev.begin() + from + ps->inf_count);
        w.side_inf_phi.insert(w.side_inf_phi.end(), w.side_inf_phi_prev.begin() + from,
                              w.side_inf_phi_prev.begin() + from + ps->inf_count);
        side.inf_begin = begin;
        side.inf_count = ps->inf_count;
        side.w_deform = ps->w_deform;
      } else {
        BuildSideInfluence(w, b, &side);
      }
      row.w_diag += side.w_deform * Mat3::Identity();  // isotropic kernel: frame R R^T frame^T = I
      const Vec3 uf = b.pose.Rotate(SideDisplacement(side, b.u_free));
      const Vec3 up = b.pose.Rotate(SideDisplacement(side, b.u));
      gap_def += side.sign * c.normal.dot(uf);
      // the rigid motion of the displaced point is in the rigid part (J at anchor + u)
      slip_def += side.sign * (uf - up);
      row.gap_start += side.sign * c.normal.dot(up);
    }
    FinishRow(w, &row, gap_def, slip_def, &warm_forces);
  }
  // the solver's pointers to the merged influences (the buffers have stopped growing)
  for (ContactRow& row : w.rows)
    for (ContactSide& side : row.side) {
      if (side.inf_count == 0) continue;
      if (side.inf_begin < 0) {
        w.bodies[side.body].deform.Influence(side.idx[0], &side.inf_idx, &side.inf_phi);
      } else {
        side.inf_idx = w.side_inf_idx.data() + side.inf_begin;
        side.inf_phi = w.side_inf_phi.data() + side.inf_begin;
      }
    }
  const auto t2 = Clock::now();
  w.profile.fill_w_rigid = std::chrono::duration<double>(t1 - t0).count();
  w.profile.fill_w_deform = std::chrono::duration<double>(t2 - t1).count();
}

}  // namespace gs
