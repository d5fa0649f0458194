// report.json of `ieslam run` (the keys the command-line interface promises and more).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/dataset.h"
#include "core/json.h"
#include "selection/pipeline/dataset_run.h"

namespace ieslam {

// `total_seconds`: the whole command's wall time, writing included, for seconds.total;
// `outputs_seconds`: the part of it spent writing the other outputs.
Json RunReport(const Dataset& dataset, const RunOptions& options, const RunResult& run,
               double total_seconds, double outputs_seconds);

// seconds' wall-time stages of the caller's thread, in the order they run: setup,
// registration (the front end's work and waits on that thread), selection, filter,
// covariance, map, evaluation, outputs, ba (with `refine`), and other (what none of them
// covers: the selector's bookkeeping between its timed steps, the problem's assembly). They
// do not overlap, so they add up to `total_seconds` with `other` >= 0.
std::vector<std::pair<std::string, double>> RunWallStages(const RunResult& run, bool refine,
                                                          double total_seconds,
                                                          double outputs_seconds);

// One log line of a selector decision (for --verbose): its candidates with their gains and
// map terms, and the frames added; frames by their index in the dataset.
std::string DescribeDecision(const SelectionDecision& decision, const Dataset& dataset);

// The frames' indices in the dataset (before --first/--last/--stride), as reports name them.
std::vector<int> SourceIndices(const Dataset& dataset, const std::vector<int>& frames);

}  // namespace ieslam
