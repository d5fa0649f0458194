// report.json of a run on the 9 real frames of tum-fr1-desk-9.
#include "selection/pipeline/run_report.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/stopwatch.h"

namespace ieslam {
namespace {

const std::string kDesk = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-fr1-desk-9";

bool Has(const std::string& text, const std::string& key) {
  return text.find("\"" + key + "\"") != std::string::npos;
}

TEST(RunReportTest, HoldsWhatTheInterfacePromises) {
  RunOptions options;
  options.dataset = kDesk;
  options.threads = 1;
  options.pipeline.refine = true;
  options.dataset_options.first = 1;  // frames named by their index in the dataset
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  const RunResult run = RunOnDataset(*dataset, options);
  const std::string report = RunReport(*dataset, options, run, 12.5, 0.5).Dump();
  for (const char* key : {"version",
                          "dataset",
                          "seed",
                          "options",
                          "frames_total",
                          "frames_selected",
                          "frames_skipped",
                          "state_dim",
                          "poses",
                          "features",
                          "interrupted",
                          "seconds",
                          "total",
                          "frontend",
                          "selection",
                          "filter",
                          "ba",
                          "ate_rmse_m",
                          "keyframes",
                          "trajectory",
                          "refined",
                          "filter_vs_smoother",
                          "keyframe_sigmas",
                          "consistency",
                          "inside_2sigma",
                          "mean_nees",
                          "nees_band",
                          "per_keyframe",
                          "rejected_share",
                          "decisions"}) {
    EXPECT_TRUE(Has(report, key)) << key;
  }
  EXPECT_NE(report.find("\"total\": 12.5"), std::string::npos);
  EXPECT_NE(report.find("\"frames_total\": 8"), std::string::npos);
  // The first decision adds the first frame, which is frame 1 of the dataset.
  EXPECT_NE(report.find("\"added\": [1]"), std::string::npos) << report.substr(0, 400);
  EXPECT_EQ(SourceIndices(*dataset, {0, 2}), (std::vector<int>{1, 3}));
  // Both estimators' covariances are held against the ground truth, the anchor left out.
  ASSERT_TRUE(run.consistency_filter.has_value());
  ASSERT_TRUE(run.consistency_refined.has_value());
  EXPECT_EQ(run.consistency_filter->poses, static_cast<int>(run.keyframes.size()) - 1);
  EXPECT_EQ(run.consistency_refined->poses, static_cast<int>(run.keyframes.size()) - 1);
}

TEST(RunReportTest, LeavesOutWhatWasNotDone) {
  RunOptions options;
  options.dataset = kDesk;
  options.threads = 1;
  options.build_map = false;
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  const RunResult run = RunOnDataset(*dataset, options);
  const std::string report = RunReport(*dataset, options, run, 1.0, 0.0).Dump();
  EXPECT_FALSE(Has(report, "refined"));
  EXPECT_FALSE(Has(report, "filter_vs_smoother"));
  EXPECT_TRUE(Has(report, "keyframe_sigmas"));
  EXPECT_TRUE(Has(report, "consistency"));
  EXPECT_FALSE(run.consistency_refined.has_value());
}

// The stages are wall times of one thread that do not overlap: none is negative and they
// leave a non-negative remainder; and they cover the run, so the remainder is small.
TEST(RunReportTest, WallStagesPartitionTheTotal) {
  RunOptions options;
  options.dataset = kDesk;
  options.threads = 1;
  options.pipeline.refine = true;
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  const RunResult run = RunOnDataset(*dataset, options);
  const double total = SecondsSince(run.started);
  const auto stages = RunWallStages(run, true, total, 0.0);
  std::vector<std::string> names;
  double named = 0.0;
  for (const auto& [name, seconds] : stages) {
    names.push_back(name);
    if (name == "other") continue;
    EXPECT_GE(seconds, 0.0) << name;
    named += seconds;
  }
  EXPECT_EQ(names,
            (std::vector<std::string>{"setup", "registration", "selection", "filter", "covariance",
                                      "map", "evaluation", "outputs", "ba", "other"}));
  EXPECT_LE(named, total);
  EXPECT_GE(stages.back().second, 0.0);
  EXPECT_LT(stages.back().second, 0.2 * total) << "total " << total;
  for (const auto& [name, seconds] : stages) {
    if (name == "registration" || name == "filter" || name == "map" || name == "ba") {
      EXPECT_GT(seconds, 0.0) << name;
    }
  }
  // The base frames' additions to the descriptor database are timed, within the selector's
  // commits (selection time, of which registration is the front end's share).
  EXPECT_GT(run.frontend.database_s, 0.0);
  EXPECT_LE(run.frontend.database_s, run.pipeline.selection.seconds_selection);
  // Every quarter of the frames was timed, within the selection.
  const std::vector<double>& quarters = run.pipeline.selection.seconds_per_frame_by_quarter;
  ASSERT_EQ(quarters.size(), 4u);
  for (const double per_frame : quarters) {
    EXPECT_GT(per_frame, 0.0);
    EXPECT_LT(per_frame, run.pipeline.selection_wall_seconds);
  }
}

}  // namespace
}  // namespace ieslam
