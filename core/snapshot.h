// Snapshots of a World for drawing, taken by value between steps.
//
// Taking a snapshot (TakeSnapshot) is cheap and runs on the simulation thread:
// it copies poses, control-point displacements, contact forces and the step's
// figures into buffers that are reused (no allocation once they are sized).
// What is costly, moving every surface point by the displacement of the control
// points around it (paper eq. 8) and recomputing its normal, is done later and
// only for the frames that are drawn (ExpandSurfaces), from a SurfaceRig built
// once from the world's rest geometry, which never changes after Finalize.
//
// Normals: the displacement of a surface point p is
//   u(p) = sum_i w_i(p) u_i,   w_i = g_i / sum_j g_j,   g_i = exp(-|c_i - p|^2 / h^2)
// (eq. 8, over the heaviest control points DeformableModel::Interpolate keeps).
// Its gradient is G = du/dp = sum_i u_i a_i^T with
//   a_i = dw_i/dp = (2 / h^2) w_i (c_i - cbar),   cbar = sum_j w_j c_j,
// so the deformed surface's normal is n' ~ (I + G)^-T n: the exact normal of
// the interpolated surface where the rest normal is exact. a_i is precomputed.
#pragma once

#include <array>
#include <memory>
#include <string>

#include "core/sampling.h"
#include "core/types.h"

namespace gs {

class World;

/// Rest geometry and eq. 8 weights of one body's surface points.
struct SurfaceRig {
  static constexpr int kWeights = 6;
  std::string name;
  bool is_plane = false;
  bool deformable = false;
  int finger = -1;             ///< for a fingertip, its finger
  bool fixed = false;          ///< does not move (EMotion::Fixed)
  double spacing = 0.0;        ///< mean point spacing (m), for splat sizes
  ShapeDesc shape;
  std::vector<Vec3> rest_p, rest_n;  ///< rest frame
  // for deformable bodies, per point kWeights entries (unused ones have w = 0)
  std::vector<int> idx;
  std::vector<double> w;
  std::vector<Vec3> grad;      ///< a_i of the header comment
};

/// One rig per body, index for index.
struct SnapshotRig {
  std::vector<SurfaceRig> bodies;
};

/// Builds the rig from a finalized world (allocates; once).
std::shared_ptr<const SnapshotRig> BuildSnapshotRig(const World& w);

struct BodyState {
  Pose pose;
  std::vector<Vec3> u;  ///< control-point displacements (rest frame, m); empty when rigid
  bool moved = false;   ///< some |u| > 0
};

struct ContactState {
  Vec3 point = Vec3::Zero();   ///< world (m)
  Vec3 normal = Vec3::Zero();  ///< world, from body[1] toward body[0]
  Vec3 force = Vec3::Zero();   ///< force on body[0] (N, world)
  int body[2] = {-1, -1};
  bool slip = false;           ///< on the friction cone's boundary (sliding or about to)
};

/// A finger's chain for drawing: base (joint 1), joint 2, joint 3, distal end, fingertip centre.
struct FingerState {
  std::array<Vec3, 5> points;
  int body = -1;
};

/// Figures for the heads-up display.
struct HudState {
  double time = 0.0;          ///< simulated (s)
  int64_t step = 0;
  double step_ms = 0.0;       ///< wall time of the last step (ms); < 0: not shown (deterministic frames)
  int contacts = 0;
  int iterations = 0;
  double residual = 0.0;
  bool converged = true;
  std::string tracker = "none";  ///< tracker state, set by the caller (no tracker: "none", not shown)
};

struct WorldSnapshot {
  std::vector<BodyState> bodies;
  std::vector<ContactState> contacts;
  std::vector<FingerState> fingers;
  HudState hud;
};

/// Copies the world's drawable state into `out`, reusing its buffers.
void TakeSnapshot(const World& w, WorldSnapshot* out);

/// A body's surface as drawn: world positions and unit normals.
struct SurfaceFrame {
  std::vector<Vec3> positions, normals;
};

/// Eq. 8 displacement and recomputed normals of every surface point, in the world
/// frame (planes get empty frames). `out` is resized to the body count and reused.
void ExpandSurfaces(const SnapshotRig& rig, const WorldSnapshot& s, std::vector<SurfaceFrame>* out);

}  // namespace gs
