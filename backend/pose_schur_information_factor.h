// The information filter's matrix factored through its dense pose Schur complement
// (backend/pose_schur_factor.h). Unless asked to keep the factor exact, an update may leave
// it a preconditioner, the state then recovered by conjugate gradients (and should they not
// converge, by the factor made exact); MakeExact refactors what such updates left. A refused
// update leaves the factor as it was, so Restore has nothing to do. AddAndSolve says
// kUnsolved when S turns out numerically indefinite although the update's check (through the
// block of the poses not yet factored) passed.
#pragma once

#include <memory>

#include "backend/information_factor.h"
#include "backend/pose_schur_factor.h"

namespace ieslam {

// Throws ConfigError when the options fail Check.
std::unique_ptr<InformationFactor> MakePoseSchurInformationFactor(const PoseSchurOptions& options);

}  // namespace ieslam
