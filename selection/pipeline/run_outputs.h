// The files of a run (the command-line interface's list): keyframes.tum, trajectory.tum,
// selected_frames.txt, groundtruth.tum (with ground truth), ba_problem.txt and
// information_blocks.txt (with a filter), refined.tum (with a refinement that did not fail),
// map.ply (with a map), map/map.bin (with a saved map) and report.json, each written
// atomically.
//
// The set is consistent too: report.json, the set's commit point, is removed first and
// written last, so that a set without it is one a run did not finish. Where the directory
// held a run before (its report.json, or kRunOutputMarker, which every run leaves), the
// files of the set this run does not write (an earlier run's refined.tum, `ieslam refine`'s
// refine_report.json and refine_refined.tum) are removed before it; in any other directory
// files of those names are the user's and stay. Files of other names are never touched.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/dataset.h"
#include "selection/pipeline/dataset_run.h"

namespace ieslam {

// The empty file that marks a directory as holding a run's outputs.
inline constexpr char kRunOutputMarker[] = ".ieslam_run";

// Every name a run may write into its directory, and what `ieslam refine` writes beside them.
const std::vector<std::string>& RunOutputNames();

// Writes `run` into the existing directory `out`, first removing the temp files of these names
// that writers no longer running left there. `stop`, when set, is asked before report.json:
// true reports the run as interrupted (a signal while writing). Throws OutputError naming a
// file that cannot be written or removed.
void WriteRunOutputs(const std::string& out, const Dataset& dataset, const RunOptions& options,
                     const RunResult& run, const std::function<bool()>& stop = nullptr);

}  // namespace ieslam
