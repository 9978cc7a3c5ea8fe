// Scenes the simulator cannot resolve, refused before the first step with a
// message that says why (used by `graspsim stress`; callable on any built world).
//  - a time step so long that a body falling from rest crosses more than half
//    of its smallest sphere-tree leaf in one step: contacts would be found so
//    deep that their projection can land on the wrong side of the surface, and
//    the body tunnels through thin parts;
//  - two point-based bodies that start overlapping by more than a leaf radius:
//    the same wrong-side projections push them apart in random directions
//    (a body overlapping an analytic plane is fine: it is pushed out at
//    WorldParams::max_push_out_speed).
#pragma once

#include <string>

#include "core/world.h"

namespace gs::app {

/// Empty when the finalized world is well posed, else what is wrong (names the bodies and numbers).
std::string IllPosedReason(const World& w);

}  // namespace gs::app
