// A pinhole camera: where it is, what it looks at, its vertical field of view.
// The same matrices feed OpenGL and Project(), so tests can predict pixels.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "core/snapshot.h"
#include "core/types.h"

namespace gs::render {

using Mat4 = Eigen::Matrix4d;

struct Camera {
  Vec3 position = Vec3(0.25, -0.35, 0.2);  ///< m, world
  Vec3 target = Vec3::Zero();              ///< m, world
  Vec3 up = Vec3::UnitZ();
  double fov_deg = 35.0;                   ///< vertical field of view

  /// World to eye (OpenGL convention: the eye looks down -z).
  Mat4 View() const;
  /// Eye to clip for an image of this aspect (width / height).
  Mat4 Projection(double aspect) const;
  /// Pixel coordinates (x right from the left edge, y down from the top edge, pixel
  /// centres at .5) of a world point in a width x height image; false behind the camera.
  bool Project(const Vec3& p, int width, int height, double* x, double* y) const;
  /// Size in pixels of a length `len` (m) seen face-on at distance `depth` (m).
  double PixelsPerMetre(double depth, int height) const;
  /// A camera is usable when position != target, the fov is in (0, 180) and up is not along the view.
  bool Valid() const;
};

/// A camera framing every body but planes, and the fingers, of a snapshot: it
/// looks at their bounding box's centre from the front-right, slightly above,
/// far enough that the bounding sphere (times `margin`) fills the height.
/// `sweep`: offsets the scene will move by (a scripted hand's keyframes relative
/// to its start); the box is widened to hold every shifted copy, so that a
/// lifted object stays in the picture.
Camera DefaultCamera(const SnapshotRig& rig, const WorldSnapshot& s, double fov_deg = 35.0, double margin = 1.15,
                     const std::vector<Vec3>& sweep = {});

}  // namespace gs::render
