// RunPipeline on the paper's simulation (known data association, exact truth).
#include "selection/pipeline/pipeline.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "frontend/simulation/known_association_source.h"
#include "frontend/simulation/paper_simulation.h"

namespace ieslam {
namespace {

SimulatedDataset ShortSimulation() {
  SimulationOptions options;
  options.trajectory.num_poses = 60;
  options.trajectory.num_loops = 1;
  return SimulatePaperScenario(options);
}

PipelineResult RunOn(const SimulatedDataset& data, const PipelineOptions& options,
                     const PipelineHooks& hooks = {}, const RangeCloudLoader& clouds = nullptr) {
  std::vector<double> timestamps(data.num_poses());
  for (int k = 0; k < data.num_poses(); ++k) timestamps[k] = k;
  KnownAssociationSource source(data.observations, timestamps, data.camera,
                                PoseToIsometry(data.T_w_c_true[0]));
  return RunPipeline(&source, data.camera, options, hooks, clouds);
}

TEST(PipelineTest, GivesTheEstimateItsCovariancesAndThePosesOfEveryFrame) {
  const SimulatedDataset data = ShortSimulation();
  const PipelineResult result = RunOn(data, PipelineOptions());
  ASSERT_TRUE(result.has_estimate);
  ASSERT_EQ(result.T_w_c.size(), 60u);
  for (int frame = 0; frame < 60; ++frame) EXPECT_TRUE(result.T_w_c[frame]) << frame;
  EXPECT_EQ(result.estimate.poses.size(), result.selection.selected.size());
  EXPECT_EQ(result.estimate.pose_covariances.size(), result.selection.selected.size());
  for (const int frame : result.selection.selected) {
    EXPECT_TRUE(result.T_w_c[frame]->isApprox(PoseToIsometry(result.filter->pose(frame))));
    EXPECT_EQ(result.estimate.pose_covariances.at(frame), result.filter->PoseCovariance(frame));
  }
  // The problem holds the filter's poses, features and every observation it used: all but
  // the sightings of features still pending (seen by one pose), which constrain nothing.
  EXPECT_EQ(result.problem.T_w_c.size(), result.selection.selected.size());
  EXPECT_EQ(static_cast<int>(result.problem.p_w.size()), result.filter->num_features());
  size_t observations = 0, pending = 0;
  for (const auto& [frame, list] : result.selection.observations) {
    for (const FeatureObservation& obs : list) {
      ++(result.filter->IsPending(obs.feature_id) ? pending : observations);
    }
  }
  EXPECT_GT(pending, 0u);
  EXPECT_EQ(static_cast<int>(pending), result.filter->num_pending_features());
  EXPECT_EQ(result.problem.observations.size(), observations);
  EXPECT_FALSE(result.refinement.has_value());
}

TEST(PipelineTest, RefinesWithTheCloudsItIsGiven) {
  const SimulatedDataset data = ShortSimulation();
  PipelineOptions options;
  options.refine = true;
  options.depth_alignment.rounds = 0;
  int calls = 0;
  const RangeCloudLoader clouds = [&calls](const std::vector<int>&,
                                           const std::vector<std::optional<Eigen::Isometry3d>>&) {
    ++calls;
    return RangeClouds();
  };
  const PipelineResult no_rounds = RunOn(data, options, {}, clouds);
  ASSERT_TRUE(no_rounds.refinement.has_value());
  EXPECT_TRUE(no_rounds.refinement->smoothed.usable);
  EXPECT_FALSE(no_rounds.refinement->depth_alignment_tried);
  EXPECT_EQ(calls, 0);  // no depth alignment asked for: no clouds loaded
  options.depth_alignment.rounds = 2;
  std::vector<int> asked;
  const RangeCloudLoader record = [&](const std::vector<int>& selected,
                                      const std::vector<std::optional<Eigen::Isometry3d>>& T) {
    ++calls;
    asked = selected;
    EXPECT_EQ(T.size(), 60u);
    return RangeClouds();
  };
  const PipelineResult result = RunOn(data, options, {}, record);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(asked, result.selection.selected);
  // No clouds: the refinement is the bundle adjustment, and the filter is compared with it.
  EXPECT_FALSE(result.refinement->depth_alignment_tried);
  EXPECT_EQ(result.refinement->comparison.frames.size(), result.selection.selected.size());
  EXPECT_LT(result.refinement->comparison.translation_m.rmse, 0.05);
}

TEST(PipelineTest, StopsWhenAskedAndStillEstimates) {
  const SimulatedDataset data = ShortSimulation();
  int polls = 0;
  PipelineHooks hooks;
  hooks.stop = [&polls] { return ++polls > 3; };
  int progress_calls = 0;
  hooks.progress = [&progress_calls](int, int) { ++progress_calls; };
  const PipelineResult result = RunOn(data, PipelineOptions(), hooks);
  EXPECT_TRUE(result.selection.interrupted);
  EXPECT_LT(result.selection.frames_processed, 60);
  EXPECT_GT(progress_calls, 0);
  EXPECT_TRUE(result.has_estimate);
}

TEST(PipelineTest, DeadReckoningHasNoEstimateAndRefusesToRefine) {
  const SimulatedDataset data = ShortSimulation();
  PipelineOptions options;
  options.selector.kind = SelectorKind::kDeadReckoning;
  const PipelineResult result = RunOn(data, options);
  EXPECT_FALSE(result.has_estimate);
  EXPECT_EQ(result.selection.chained_T_w_c.size(), 60u);
  EXPECT_TRUE(result.T_w_c.back().has_value());
  options.refine = true;
  std::string why;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("deadreckoning"), std::string::npos);
  EXPECT_THROW(RunOn(data, options), ConfigError);
}

}  // namespace
}  // namespace ieslam
