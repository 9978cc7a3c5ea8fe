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
};

struct ValidationOptions {
  bool quick = false;  ///< shorter holds and coarser sampling (the test suite)
};

/// A block on a plane tilted at atan(mu) x (1 -+ 1%): sticks below, slides above.
std::vector<ValidationResult> ValidateIncline(const ValidationOptions& opt);
/// A hexagonal prism or a cylinder pinched by three fingertips pushing with force
/// P: holds for mu >= 1.005 mu*, falls for mu <= 0.995 mu*, slides at
/// g (1 - mu / mu*) below mu* = m g / (3 P); both contact modes.
std::vector<ValidationResult> ValidatePinch(const ValidationOptions& opt);
/// A fingertip dragged along a flat face at constant normal force: the tangential
/// over the normal force is mu at every step (no ripple), in both contact modes.
std::vector<ValidationResult> ValidateSlide(const ValidationOptions& opt);
/// A Boussinesq sphere pressed on a rigid plane: F ~ d^1.5 and a = sqrt(R d).
std::vector<ValidationResult> ValidateHertz(const ValidationOptions& opt);

/// The paper's grasp (config/paper_box_grasp.yaml): the box must stay within 5 mm
/// of the lift height through the hold phase; every step's residual is reported.
std::vector<ValidationResult> ValidatePaperGrasp(const ValidationOptions& opt);

/// Names accepted by `graspsim validate`.
std::vector<std::string> ValidationNames();
/// Runs one by name ("all" for every one); false when the name is unknown.
bool RunValidation(const std::string& name, const ValidationOptions& opt, std::vector<ValidationResult>* out);

}  // namespace gs::app
