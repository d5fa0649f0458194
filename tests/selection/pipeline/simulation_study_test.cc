// The Monte-Carlo study of the paper's simulation on a short trajectory.
#include "selection/pipeline/simulation_study.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

SimulationStudyOptions ShortStudy() {
  SimulationStudyOptions options;
  options.simulation.trajectory.num_poses = 40;
  options.simulation.trajectory.num_loops = 1;
  options.runs = 2;
  options.buffers = {3};
  return options;
}

TEST(SimulationStudyTest, OneRowPerSelectorWithTheMeansOverTheRuns) {
  const SimulationStudyOptions options = ShortStudy();
  std::vector<int> done;
  const SimulationStudy study =
      RunSimulationStudy(options, [&done](int rows_done, int total, const std::string&) {
        done.push_back(rows_done);
        EXPECT_EQ(total, 4);
      });
  EXPECT_EQ(done, (std::vector<int>{1, 2, 3, 4}));
  EXPECT_EQ(study.runs_done, 2);
  EXPECT_FALSE(study.interrupted);
  ASSERT_EQ(study.rows.size(), 2u);
  EXPECT_EQ(study.rows[0].selector, "all");
  EXPECT_EQ(study.rows[0].buffer, 0);
  EXPECT_EQ(study.rows[1].selector, "info");
  EXPECT_EQ(study.rows[1].buffer, 3);
  EXPECT_EQ(study.rows[0].frames_used, 40.0);
  EXPECT_LT(study.rows[1].frames_used, study.rows[0].frames_used);
  EXPECT_GT(study.rows[1].refined_ate_rmse_m, 0.0);
  // The NEES band is that of the mean over 2 runs of a 6-dimensional state.
  EXPECT_LT(study.rows[0].nees_band.first, 6.0);
  EXPECT_GT(study.rows[0].nees_band.second, 6.0);
  // Only the first run's per-pose errors are kept: one entry per row.
  ASSERT_TRUE(study.first_run_pose_errors.is_array());
  EXPECT_NE(study.first_run_pose_errors.Dump().find("\"selector\": \"info\""), std::string::npos);
  const std::string markdown = StudyMarkdown(study, options);
  EXPECT_NE(markdown.find("| info | 3 |"), std::string::npos) << markdown;
  EXPECT_NE(markdown.find("Ratios to the all-frames EIF"), std::string::npos) << markdown;
  EXPECT_NE(StudyRowsToJson(study.rows).Dump().find("\"refined_not_worse\""), std::string::npos);
}

// Stopped in the second run: the table covers the first; stopped in the first, its rows done.
TEST(SimulationStudyTest, AStoppedStudyKeepsTheRunsItCompleted) {
  const SimulationStudyOptions options = ShortStudy();
  int polls = 0;
  const SimulationStudy second =
      RunSimulationStudy(options, nullptr, [&polls] { return ++polls > 4; });
  EXPECT_TRUE(second.interrupted);
  EXPECT_EQ(second.runs_done, 1);
  EXPECT_EQ(second.rows.size(), 2u);
  polls = 0;
  const SimulationStudy first =
      RunSimulationStudy(options, nullptr, [&polls] { return ++polls > 2; });
  EXPECT_TRUE(first.interrupted);
  EXPECT_EQ(first.runs_done, 1);
  ASSERT_EQ(first.rows.size(), 1u);
  EXPECT_EQ(first.rows[0].selector, "all");
}

TEST(SimulationStudyTest, OptionsAreChecked) {
  SimulationStudyOptions options = ShortStudy();
  options.runs = 0;
  EXPECT_THROW(RunSimulationStudy(options), ConfigError);
  options = ShortStudy();
  options.buffers.clear();
  EXPECT_THROW(RunSimulationStudy(options), ConfigError);
}

}  // namespace
}  // namespace ieslam
