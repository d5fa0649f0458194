// The files of a run (the command-line interface's list): keyframes.tum, trajectory.tum,
// selected_frames.txt, groundtruth.tum (with ground truth), ba_problem.txt and
// information_blocks.txt (with a filter), refined.tum (with --refine), map.ply (with a map)
// and report.json, each written atomically, report.json last.
#pragma once

#include <string>

#include "core/dataset.h"
#include "selection/pipeline/dataset_run.h"

namespace ieslam {

// Writes `run` into the existing directory `out`. Throws DataError naming a file that cannot
// be written.
void WriteRunOutputs(const std::string& out, const Dataset& dataset, const RunOptions& options,
                     const RunResult& run);

}  // namespace ieslam
