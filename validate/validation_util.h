// What every validation family shares: g, and the result of one case.
#pragma once

#include <cmath>
#include <string>

#include "core/world.h"
#include "scene/code_scenes.h"
#include "session/console.h"
#include "validate/validation.h"

namespace gs::app {

inline constexpr double kG = 9.81;

/// One case: pass when the error is finite and within the tolerance. A case whose
/// result is made after a stop request (Ctrl-C, SIGTERM) was cut short: it has no
/// verdict. A case run in a contact mode has it in its name too ("_two-pass" added
/// where the name does not say it), so that every case of a run has its own name.
inline ValidationResult Result(const std::string& name, double error, double tolerance, const std::string& unit,
                               const std::string& detail, const std::string& contact_mode = "") {
  ValidationResult r;
  const bool says_mode = contact_mode.empty() || name.find(contact_mode) != std::string::npos;
  r.name = says_mode ? name : name + "_" + contact_mode;
  r.error = error;
  r.tolerance = tolerance;
  r.interrupted = StopRequested();
  r.pass = !r.interrupted && std::isfinite(error) && error <= tolerance;
  r.unit = unit;
  r.detail = detail;
  r.contact_mode = contact_mode;
  return r;
}

/// The tilted surface of the incline and roll families, its top face through the
/// origin of `slope` (normal slope.R z): the analytic plane, or a fixed rigid box slab
/// of half extents `half` and `points` / `control_points`, in two-pass contact (its
/// control points projected too) or one-pass.
enum class ETiltedSurface { Plane, SlabTwoPass, SlabOnePass };
inline void AddTiltedSurface(World& w, ETiltedSurface surface, const Pose& slope, const Vec3& half, int points,
                             int control_points) {
  if (surface == ETiltedSurface::Plane) {
    AddBody(w, PlaneSpec("plane", slope));
    return;
  }
  BodySpec s;
  s.name = "slab";
  s.shape.type = EShape::Box;
  s.shape.half_extents = half;
  s.geometry.points = points;
  s.geometry.control_points = control_points;
  s.motion = EMotion::Fixed;
  s.pose = Pose{slope.R, slope.Apply(Vec3(0, 0, -half.z()))};
  s.emits_contacts = surface == ETiltedSurface::SlabTwoPass;
  AddBody(w, s);
}
inline const char* ModeName(ETiltedSurface s) {
  return s == ETiltedSurface::SlabTwoPass ? "two-pass" : s == ETiltedSurface::SlabOnePass ? "one-pass" : "";
}

}  // namespace gs::app
