// report.json of `ieslam run` (the keys the command-line interface promises and more).
#pragma once

#include "core/dataset.h"
#include "core/json.h"
#include "selection/pipeline/dataset_run.h"

namespace ieslam {

// `total_seconds`: the whole command's wall time, writing included, for seconds.total.
Json RunReport(const Dataset& dataset, const RunOptions& options, const RunResult& run,
               double total_seconds);

// One log line of a selector decision (for --verbose): its candidates with their gains and
// map terms, and the frames added; frames by their index in the dataset.
std::string DescribeDecision(const SelectionDecision& decision, const Dataset& dataset);

// The frames' indices in the dataset (before --first/--last/--stride), as reports name them.
std::vector<int> SourceIndices(const Dataset& dataset, const std::vector<int>& frames);

}  // namespace ieslam
