// What every validation family shares: g, and the result of one case.
#pragma once

#include <cmath>
#include <string>

#include "session/console.h"
#include "validate/validation.h"

namespace gs::app {

inline constexpr double kG = 9.81;

/// One case: pass when the error is finite and within the tolerance. A case whose
/// result is made after a stop request (Ctrl-C, SIGTERM) was cut short: it has no
/// verdict.
inline ValidationResult Result(const std::string& name, double error, double tolerance, const std::string& unit,
                               const std::string& detail, const std::string& contact_mode = "") {
  ValidationResult r;
  r.name = name;
  r.error = error;
  r.tolerance = tolerance;
  r.interrupted = StopRequested();
  r.pass = !r.interrupted && std::isfinite(error) && error <= tolerance;
  r.unit = unit;
  r.detail = detail;
  r.contact_mode = contact_mode;
  return r;
}

}  // namespace gs::app
