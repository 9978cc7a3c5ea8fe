// Scenes the simulator cannot resolve, found once the bodies are sampled and
// refused before the first step with what is wrong, the rule and the value to use.
// Every command that loads a scene (run, replay, live, scene check, through
// BuildScene in scene/scene_file.cpp) and `graspsim stress` (worlds built in code)
// apply the same checks:
//  - a time step so long that a free body, falling from its initial velocity,
//    moves more than half of its smallest sphere-tree leaf in one step (contacts
//    would be found so deep that their projection can land on the wrong side of
//    the surface, and the body tunnels through thin parts), or farther than the
//    thinnest other body reaches from its centre (Body::core_radius: it can pass
//    through that body in one step);
//  - two point-based bodies that start overlapping by more than a leaf radius
//    (the deepest contact found, or the overlap of the balls about their centres
//    that lie inside them, Body::core_radius, for overlaps too deep to project):
//    the same wrong-side projections push them apart in random directions
//    (a body overlapping an analytic plane is fine: it is pushed out at
//    WorldParams::max_push_out_speed);
//  - one-pass contact on a Boussinesq surface by a body whose control points are
//    more than 1.4 times farther apart than the surface's: the surface bulges
//    between them and the contact is too soft (docs/collision.md);
//  - one-pass contact on a curved surface (sphere, capsule, cylinder, ellipsoid) by a
//    body whose control points are so far apart that the surface, resting on them,
//    sinks between them deeper than its smallest leaf (docs/collision.md).
#pragma once

#include <string>
#include <vector>

#include "core/world.h"

namespace gs::app {

/// One problem of a finalized world; `body` (and `other` for an overlap) index w.bodies.
struct IllPosed {
  enum class ESite { TimeStep, Overlap, Sampling };
  ESite site = ESite::TimeStep;
  int body = -1, other = -1;  ///< Sampling: `body` emits contacts onto `other`
  std::string message;
};

/// Every problem: at most one time step (the body that needs the shortest), every overlapping pair.
std::vector<IllPosed> FindIllPosed(const World& w);

/// Empty when the finalized world is well posed, else the first problem's message.
std::string IllPosedReason(const World& w);

/// On a sampled face the widest gap between control points (the radius of the
/// largest circle free of them) is this much of their spacing sqrt(area / n): 0.89 to
/// 0.96 on a 6 cm box at 400 to 4,800 control points (tests/app/scene_test.cpp).
constexpr double kGapPerSpacing = 0.96;

/// How deep a rigid surface of curvature radius `radius` sinks between control points
/// `spacing` apart (m): the sagitta of the cap spanning their widest gap; the whole
/// radius when the gap is as wide as the surface.
double SinkBetweenControlPoints(double radius, double spacing);

/// The longest time step at which body b moves at most half its smallest leaf in one
/// step from its initial velocity under gravity g (s); infinite when it cannot move.
double LongestTimeStep(const Body& b, double g);

}  // namespace gs::app
