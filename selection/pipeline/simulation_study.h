// The paper's Table I and its consistency figures (§VI-A) over Monte-Carlo runs: the
// all-frames EIF against the information-efficient selector with several look-ahead
// buffers, every run on one scene with fresh measurement noise, each row's estimate also
// bundle-adjusted.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "backend/bundle_adjustment.h"
#include "backend/information_filter.h"
#include "core/json.h"
#include "frontend/simulation/paper_simulation.h"
#include "selection/keyframe_selector.h"
#include "selection/pipeline/known_association_run.h"
#include "selection/pipeline/run_options.h"

namespace ieslam {

// The options a study starts from: run's without the observation gate. The paper's
// experiment knows its data association and draws the noise its Q states, so the gate would
// reject nothing it should and add its cost to the filters Table I times; a study's own
// options may turn it on.
RunOptions StudyRunOptions();

struct SimulationStudyOptions {
  SimulationOptions simulation;  // the scene (its scene_seed) and the sensor
  int runs = 1;
  // The first run's index: a shard of a larger study runs first_run .. first_run + runs - 1,
  // each drawing the noise one process running them all would.
  int first_run = 0;
  uint32_t seed = 1;                        // scene seed; run r draws its noise from seed + r + 1
  std::vector<int> buffers = {2, 3, 4, 5};  // one info row each, after the all-frames row
  SelectorOptions selector;                 // every row's, but for its kind and buffer
  InformationFilterOptions filter = StudyRunOptions().pipeline.filter;
  BundleAdjustmentOptions ba;

  bool Check(std::string* why) const;
  // The rows' selector options: all frames, then info with each buffer.
  std::vector<SelectorOptions> Rows() const;
};

// One row of the table: the means over the runs.
struct StudyRow {
  std::string selector;
  int buffer = 0;  // 0 for the all-frames row
  double frames_total = 0, frames_used = 0, state_dim = 0, seconds = 0, final_pose_error_m = 0,
         ate_rmse_m = 0, mean_nees = 0, within_2sigma = 0, refined_ate_rmse_m = 0,
         refined_not_worse = 0, seconds_ba = 0, seconds_selection = 0, seconds_filter = 0;
  std::pair<double, double> nees_band;  // of the mean NEES over the runs (6 dof)
};

// One run's values of one row: what the row's means are computed from.
struct StudyRunValues {
  double frames_total = 0, frames_used = 0, state_dim = 0, seconds = 0, seconds_selection = 0,
         seconds_filter = 0, final_pose_error_m = 0, ate_rmse_m = 0, mean_nees = 0,
         within_2sigma = 0, refined_ate_rmse_m = -1, seconds_ba = 0;
};

// A row's values over the runs, in run order.
struct StudyRowRuns {
  std::string selector;
  int buffer = 0;  // 0 for the all-frames row
  std::vector<StudyRunValues> runs;
};

struct SimulationStudy {
  std::vector<StudyRow> rows;          // the rows every completed run has
  std::vector<StudyRowRuns> row_runs;  // every row's per-run values (rows then runs)
  int first_run = 0;                   // the index of row_runs' first run
  int runs_done = 0;
  bool interrupted = false;
  // The first run's (run first_run's) per-pose errors, sigmas and NEES of every row: the
  // paper's Figs. 3-4. Left empty by a merge of shards.
  Json first_run_pose_errors = Json::Array();
};

// Runs the study. `progress` (optional) is called after each row of each run with (rows done,
// rows in all, what was done); `stop` (optional) is polled before each row: a run cut short
// is left out, unless it is the first (then its finished rows stand).
SimulationStudy RunSimulationStudy(
    const SimulationStudyOptions& options,
    const std::function<void(int, int, const std::string&)>& progress = nullptr,
    const std::function<bool()>& stop = nullptr);

// The means of the rows over their first `runs_done` runs; a row with fewer runs is left out.
// Sums in run order with weight 1 / runs_done, so that the same per-run values give the same
// bits whether one process ran them or shards did (and a merge recomputes them).
std::vector<StudyRow> MeanStudyRows(const std::vector<StudyRowRuns>& row_runs, size_t runs_done);

// report.json's "table" and table.md.
Json StudyRowsToJson(const std::vector<StudyRow>& rows);
std::string StudyMarkdown(const SimulationStudy& study, const SimulationStudyOptions& options);

}  // namespace ieslam
