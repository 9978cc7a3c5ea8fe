// The least friction coefficient with which a body's contacts could hold it at
// rest: given the normal forces the step found on it, the smallest mu for which
// some tangential forces, each within mu times its contact's normal force, put
// the body in static equilibrium with its weight (forces and torques about its
// centre). A grasp analysis independent of the solver: the tangential forces are
// not the step's but the best ones, found by a barrier method over every
// tangential distribution in equilibrium (a second-order cone program). On a free
// body the forces act where the step applied them (ContactSide::lever: the material
// point, on a deformable body the anchor displaced by u; the normal force about where
// the rest surfaces touch, ContactSide::spin); on other bodies at the contact point.
//
// A body held by a hand whose friction drops below this mu cannot stay at rest
// with these normal forces; above it, some distribution holds it. Used to check
// that a simulated grasp lets go where Coulomb's law says it must (the whole hand's
// pinch and power grasp, validate/validate_whole_hand.cpp).
#pragma once

#include "core/world.h"

namespace gs {

struct HoldingFriction {
  double mu = 0.0;         ///< the least holding friction; +inf when no friction holds it (too few contacts)
  int contacts = 0;        ///< contacts on the body that push (normal force > 0)
  double net_force = 0.0;  ///< |net force| of the step's own contact forces and the weight (N): how static it is
  double net_torque = 0.0; ///< |net torque| about the centre of the same (N m)
  double unreached = 0.0;  ///< the part of the load no tangential force can balance (N and N m together; 0 in a static hold)
};

/// The least holding friction of body `body` from the contacts of the last step.
HoldingFriction LeastHoldingFriction(const World& w, int body);

}  // namespace gs
