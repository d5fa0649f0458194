// The information filter's matrix factored by a sparse Cholesky factor (CHOLMOD,
// backend/sparse_cholesky.h): updated in place while it has room for the new variables,
// refactored otherwise. Always exact: AddAndSolve's keep_exact and guess do not matter, and
// MakeExact has nothing to do. AddDeferred notes which variables the update touches, for
// the next ordering; Restore refactors the old matrix if a refused update dropped the factor.
#pragma once

#include <memory>

#include "backend/information_factor.h"
#include "backend/sparse_cholesky.h"

namespace ieslam {

// Throws ConfigError when the options fail Check.
std::unique_ptr<InformationFactor> MakeSparseInformationFactor(
    const SparseCholeskyOptions& options);

}  // namespace ieslam
