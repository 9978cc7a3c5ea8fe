// Generated frictional contact problems of the kinds Gauss-Seidel finds hard,
// for tests and benchmarks (FcProblem, fc_problem.h). Every problem is
// W = H M^-1 H~^T of rigid bodies (6 dof each, the ground fixed) with per-contact
// frames (normal first), q = H v_free + gap (gap >= 0: some contacts start open),
// so that the velocities v = 0 are admissible and a solution exists. All are
// deterministic in `seed` (std::mt19937_64), and pass CheckFcProblem.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/fc_problem.h"

namespace gs {

/// One rigid box (0.2 kg, 6 x 4 x 10 cm) held by `contacts` contacts (at least
/// 7) in five patches of 1 cm: a palm under it and four fingertips on its sides,
/// the box moving at up to 10 cm/s and 2 rad/s besides falling. W has rank <= 6
/// (statically indeterminate, nearly parallel rows within a patch); the rows of
/// each contact are scaled by a factor in [1, 10] (diagonal spread up to 100x,
/// as contacts of different stiffness or units give); W is slightly asymmetric:
/// H~ differs from H by frames turned by 1e-3 rad (frames taken at two
/// configurations). mu uniform in [0.3, 1]. The shape of the real FCLIB problems
/// on which NSGS stalls at 1e-3 (one object, 23-25 contacts).
FcProblem GrippedBodyProblem(int contacts, uint64_t seed);

/// The gripped body's settings (the defaults are GrippedBodyProblem's).
struct GrippedBody {
  double patch_radius = 5e-3;     ///< m: half width of a patch
  double normal_spread = 0.05;    ///< normals tilted by up to about this (rad)
  double drift = 0.1, spin = 2.0;  ///< free velocity besides gravity (m/s, rad/s)
  double diagonal_spread = 100.0;  ///< largest ratio of two contacts' diagonal
  double tilt = 1e-3;             ///< rad: H~'s frames against H's (asymmetry)
  double mu_lo = 0.3, mu_hi = 1.0;
};
FcProblem GrippedBodyProblem(int contacts, uint64_t seed, const GrippedBody& settings);

/// One stack of `boxes` boxes (4 corner contacts each, the bottom one on the
/// ground), the masses growing geometrically from 1 kg at the bottom to `ratio`
/// kg at the top (heavy on light). mu uniform in [0.1, 1].
FcProblem MassRatioStackProblem(int boxes, double ratio, uint64_t seed);

/// A pile of `bodies` boxes in layers (about sqrt(bodies) per layer): each body
/// rests on one to three bodies of the layer below (or on the ground) through
/// one to three contacts each, with normals tilted up to 0.4 rad; masses
/// log-uniform in [0.3, 3] kg; mu uniform in [mu_lo, mu_hi].
FcProblem PileProblem(int bodies, double mu_lo, double mu_hi, uint64_t seed);

/// Extreme friction: a stack of 3 boxes pushed sideways (12 contacts), every
/// contact with the same `mu` (mu -> 0: nearly frictionless, W_TT large against
/// the cone; mu = 10: almost everything sticks).
FcProblem ConeProblem(double mu, uint64_t seed);

/// A named generated problem.
struct FcFamilyCase {
  std::string name;  ///< e.g. "gripped_24_s1"
  FcProblem problem;
};

/// The families above at the sizes used by the tests and `bench solver`:
/// gripped bodies with 12, 24 and 48 contacts, mass-ratio stacks (ratio 1000,
/// 4 and 10 boxes), piles (60 and 400 bodies), cones (mu 1e-3 and 10), each for
/// `seeds` seeds starting at 1. `quick` drops the 400-body pile.
std::vector<FcFamilyCase> FcFamilySuite(int seeds, bool quick);

}  // namespace gs
