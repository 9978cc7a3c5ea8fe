// Closed-form eigen decomposition of a symmetric 3x3 matrix (no iterative solver).
#pragma once

#include "core/types.h"

namespace gs {

/// Eigenvalues in ascending order and the matching unit eigenvectors (columns).
void SymmetricEigen3(const Mat3& A, Vec3* values, Mat3* vectors);

/// Unit eigenvector of the smallest eigenvalue (the MLS normal direction).
Vec3 SmallestEigenvector(const Mat3& A);

}  // namespace gs
