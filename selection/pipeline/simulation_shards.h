// A Monte-Carlo study split into shards: each shard runs a range of runs (its runs' seeds,
// SimulationStudyOptions::first_run) and writes runs.tsv, every per-run value its table's
// means come from; a merge of the shards' files gives the table one process running all the
// runs gives, to the bit.
#pragma once

#include <string>
#include <vector>

#include "selection/pipeline/simulation_study.h"

namespace ieslam {

// What every shard of one study must agree on, and the runs this shard holds.
struct StudyShard {
  std::string path;  // the runs.tsv it was read from (for messages)
  uint32_t seed = 1;
  std::string trajectory;  // ToString(SimulatedTrajectoryKind)
  int poses = 0;
  std::vector<int> buffers;
  std::string options_json;  // StudyOptionsJson, one line
  SimulationStudy study;     // row_runs, first_run, runs_done (rows and means left empty)
};

// The selector, filter and bundle-adjustment options of the study (report.json's).
Json StudyOptionsJson(const SimulationStudyOptions& options);

// runs.tsv: a header of `# key<TAB>value` lines (seed, trajectory, poses, buffers, options,
// first_run, runs), then one line per (run, row) in run order, the values printed with 17
// significant digits so that they read back to the same doubles.
std::string StudyRunsTsv(const SimulationStudy& study, const SimulationStudyOptions& options);

// Reads a runs.tsv. DataError naming the file and the line when it is malformed or
// truncated (a run without every row, fewer runs than its header says).
StudyShard ReadStudyRunsTsv(const std::string& path);

// The shards as one study: runs in order, the means recomputed with MeanStudyRows. DataError
// naming the shard's file when shards disagree on seed, trajectory, poses, buffers or
// options, or their runs overlap or leave a gap. `shards` are in any order.
StudyShard MergeStudyShards(std::vector<StudyShard> shards);

}  // namespace ieslam
