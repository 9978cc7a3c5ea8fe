// Validation scenes: physics with a known answer, each reporting its measured
// error and whether it is within the stated tolerance.
#pragma once

#include <string>
#include <vector>

namespace gs::app {

struct ValidationResult {
  std::string name;
  double error = 0.0;      ///< the measured error, in the unit `unit` names
  double tolerance = 0.0;  ///< pass when error <= tolerance
  bool pass = false;
  std::string unit;
  std::string detail;      ///< what was measured, in words
  std::string contact_mode;  ///< "two-pass" or "one-pass" where the case depends on it, else empty
  bool interrupted = false;  ///< stopped by Ctrl-C or SIGTERM before its end: no verdict (pass is false)
};

struct ValidationOptions {
  bool quick = false;  ///< shorter holds and coarser sampling (the test suite)
};

/// A block on a surface tilted at 0.9, 0.99, 1.01, 1.1 atan(mu) (quick: 0.99, 1.01), mu
/// 0.4 and 0.8: sticks below, slides at g (sin a - mu cos a) above; on the analytic
/// plane and on a box slab in both contact modes.
std::vector<ValidationResult> ValidateIncline(const ValidationOptions& opt);
/// A hexagonal prism or a cylinder pinched by three fingertips pushing with force
/// P: holds for mu >= 1.005 mu*, falls for mu <= 0.995 mu*, slides at
/// g (1 - mu / mu*) below mu* = m g / (3 P); both contact modes.
std::vector<ValidationResult> ValidatePinch(const ValidationOptions& opt);
/// A solid ball let go on a surface tilted by 20 degrees: at mu 0.5 it rolls at 5/7 g
/// sin a with its spin keeping pace, at mu 0.05 it slides at g (sin a - mu cos a) and spins up
/// at 5 mu g cos a / (2 r); rigid, Gaussian and Boussinesq on the analytic plane, rigid
/// on a box slab in both contact modes.
std::vector<ValidationResult> ValidateRoll(const ValidationOptions& opt);
/// A fingertip dragged along a flat face at constant normal force: the tangential
/// over the normal force is mu at every step (no ripple), in both contact modes.
std::vector<ValidationResult> ValidateSlide(const ValidationOptions& opt);
/// A Boussinesq sphere pressed on a rigid plane, and a rigid sphere on a Boussinesq
/// box in both contact modes: exponent and contact radius against Sneddon's exact
/// sphere on a half-space, depth against Hertz's for the scene's E and nu.
std::vector<ValidationResult> ValidateHertz(const ValidationOptions& opt);

/// The paper's grasp (config/paper_box_grasp.yaml): the box must stay within 5 mm
/// of the lift height through the hold phase; every step's residual is reported.
std::vector<ValidationResult> ValidatePaperGrasp(const ValidationOptions& opt);

/// A heavy box 5 mm off-centre on a light one (mass ratios 1 to 1,000), friction,
/// default solver settings: neither box may walk faster than 1 um/s.
std::vector<ValidationResult> ValidateStack(const ValidationOptions& opt);
/// The stack with every mass x10 and x1000: the same trajectory and sweeps.
std::vector<ValidationResult> ValidateScale(const ValidationOptions& opt);

/// The tracked whole hand's pinch and power grasp (config/tracked_whole_hand.yaml,
/// config/whole_hand_power_grasp.yaml, the synthetic hand), friction lowered in stages
/// of the least holding friction mu* of the state it is in: holds at 1.01 mu*, slips at
/// 0.99 mu* (into a state the friction covers, or out of the hand); both contact modes.
std::vector<ValidationResult> ValidateWholeHand(const ValidationOptions& opt);

/// Names accepted by `graspsim validate`.
std::vector<std::string> ValidationNames();
/// Runs one by name ("all" for every one); false when the name is unknown. Once a
/// stop is requested (session/console.h) the case running is cut short and comes
/// back marked interrupted, and no further case or family is run.
bool RunValidation(const std::string& name, const ValidationOptions& opt, std::vector<ValidationResult>* out);

}  // namespace gs::app
