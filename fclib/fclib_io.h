// FCLIB local problems (HDF5, the nonsmooth-mechanics exchange format) to and
// from FcProblem. Built on libfclib when found (GRASPSIM_HAVE_FCLIB); without it
// every call fails with a message saying so.
//
// libfclib's readers call exit(1) when a group or dataset is missing, so the
// reader first checks with HDF5 that every object it will read is there, and
// refuses mixed problems (V, R) which our solver does not handle.
#pragma once

#include <string>

#include "core/fc_problem.h"

namespace gs::app {

/// True when graspsim was built with FCLIB.
bool FclibAvailable();

/// Reads the local problem of an FCLIB file. False with a message naming the
/// file and what is wrong (missing, not HDF5, not a local problem, bad sizes...).
bool ReadFclibLocal(const std::string& path, FcProblem* out, std::string* error);

/// Writes a local problem (W stored compressed-column), replacing the file.
/// `guess`, when not null and of size 3n, is stored as the problem's solution.
bool WriteFclibLocal(const std::string& path, const FcProblem& p, const std::string& title,
                     const std::string& description, const Eigen::VectorXd* solution, std::string* error);

}  // namespace gs::app
