// What `ieslam run` records for the paper's figures beyond the trajectories: the final pose
// uncertainty of every keyframe (Figs. 3-4 with real data, Fig. 12) and the block pattern of
// the final information matrix (Fig. 8). scripts/plot.py draws them.
#pragma once

#include <map>
#include <string>

#include "backend/evaluation/filter_smoother_comparison.h"
#include "core/json.h"

namespace ieslam {

class InformationFilter;

// [{frame, timestamp, sigma: [x, y, z (m), alpha, beta, gamma (rad)]}] from the estimate's
// pose covariances, in frame order; `timestamps` holds every pose's.
Json PoseSigmasToJson(const SlamEstimate& estimate, const std::map<int, double>& timestamps);

// Writes the information matrix's nonzero pattern at the level of state blocks, in state
// order: a line `blocks <kinds>` (one letter per block, P = pose, F = feature) and one line
// `i j` per nonzero off-diagonal block (i < j). Atomic.
void WriteInformationBlocks(const InformationFilter& filter, const std::string& path);

}  // namespace ieslam
