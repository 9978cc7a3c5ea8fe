// Is a world's problem well posed? Every parameter the step divides by or
// inverts is checked against the range where the mechanics make sense, so that
// a world that would step into NaN (a free body of zero mass: its free motion
// solves 0 * dq = m g) is refused before its first step instead of having every
// step rejected. The scene loader reports the same conditions with a file,
// line and column (scene/scene_file.cpp); this is the backstop for worlds built
// in code and for what the file cannot see (a mesh body's inertia).
#pragma once

#include <string>

#include "core/world.h"

namespace gs {

/// Empty when every parameter is in range, else what is wrong, naming the body,
/// finger or parameter and the expected range. Call after Finalize().
///  - WorldParams: dt > 0, gravity finite, solver tolerance in (0, 1), at least one
///    sweep, over-relaxation in (0, 2), friction coefficients finite and >= 0,
///    contact threshold and push-out speed finite and >= 0;
///  - every body: finite pose (R a rotation), velocity;
///  - a free body: mass finite and > 0 (inertial) and, with its drive, a free-motion
///    matrix A = M/dt^2 + B/dt + K + D/dt that is symmetric positive definite in
///    translation and rotation (the inertial model needs a positive definite inertia;
///    the quasi-static one a positive damping, or drive gains, on every axis);
///  - a deformable body: stiffness or Young's modulus finite and > 0, damping finite
///    and >= 0, Poisson ratio in [0, 0.5), influence radius finite and > 0 (Gaussian);
///  - a finger: links finite and > 0, joints and limits finite and ordered, motor
///    stiffness finite and > 0, dampings finite and >= 0.
std::string WellPosedError(const World& w);

/// Smallest and largest eigenvalue of a symmetric 3x3 matrix's symmetric part.
void SymmetricRange(const Mat3& m, double* lo, double* hi);

}  // namespace gs
