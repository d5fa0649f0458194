// The batch refinement of a filter's estimate on the paper's simulation.
#include "selection/pipeline/refinement.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "frontend/simulation/known_association_source.h"
#include "frontend/simulation/paper_simulation.h"
#include "selection/pipeline/pipeline.h"

namespace ieslam {
namespace {

TEST(RefinementTest, BundleAdjustsAndComparesWithTheFilter) {
  SimulationOptions simulation;
  simulation.trajectory.num_poses = 50;
  simulation.trajectory.num_loops = 1;
  const SimulatedDataset data = SimulatePaperScenario(simulation);
  std::vector<double> timestamps(data.num_poses());
  for (int k = 0; k < data.num_poses(); ++k) timestamps[k] = 100.0 - k;  // decreasing
  KnownAssociationSource source(data.observations, timestamps, data.camera,
                                PoseToIsometry(data.T_w_c_true[0]));
  const PipelineResult filtered = RunPipeline(&source, data.camera, PipelineOptions());
  const Refinement refinement = Refine(filtered.problem, data.camera, filtered.estimate,
                                       BundleAdjustmentOptions(), DepthAlignmentOptions());
  EXPECT_TRUE(refinement.smoothed.usable);
  EXPECT_FALSE(refinement.depth_alignment_tried);
  EXPECT_EQ(&refinement.refined(), &refinement.smoothed);
  EXPECT_EQ(refinement.comparison.frames.size(), filtered.selection.selected.size());
  EXPECT_GT(refinement.comparison.translation_m.rmse, 0.0);
  EXPECT_LT(refinement.comparison.translation_m.rmse, 0.05);
  EXPECT_TRUE(refinement.warnings.empty());
  // In time order, with each frame's timestamp.
  std::map<int, double> stamps;
  for (const auto& [frame, T] : filtered.problem.T_w_c) stamps[frame] = timestamps[frame];
  const Trajectory trajectory = RefinedTrajectory(refinement, stamps);
  ASSERT_EQ(trajectory.size(), filtered.problem.T_w_c.size());
  EXPECT_TRUE(std::is_sorted(
      trajectory.begin(), trajectory.end(),
      [](const TimedPose& a, const TimedPose& b) { return a.timestamp < b.timestamp; }));
  EXPECT_EQ(trajectory.back().timestamp, 100.0);
  EXPECT_EQ(trajectory.back().T_w_c.matrix(), refinement.smoothed.T_w_c.at(0).matrix());
  const std::string json = RefinementToJson(refinement).Dump();
  EXPECT_NE(json.find("\"ba\""), std::string::npos);
  EXPECT_NE(json.find("\"residual_check\""), std::string::npos);
  EXPECT_EQ(json.find("\"depth_alignment\""), std::string::npos);
}

// A short simulation through the filter: a problem and the filter's estimate.
PipelineResult FilteredSimulation(SimulatedDataset* data) {
  SimulationOptions simulation;
  simulation.trajectory.num_poses = 20;
  simulation.trajectory.num_loops = 1;
  *data = SimulatePaperScenario(simulation);
  std::vector<double> timestamps(data->num_poses());
  for (int k = 0; k < data->num_poses(); ++k) timestamps[k] = k;
  KnownAssociationSource source(data->observations, timestamps, data->camera,
                                PoseToIsometry(data->T_w_c_true[0]));
  return RunPipeline(&source, data->camera, PipelineOptions());
}

// Ceres' summary says "usable" for a problem without residuals; no refinement came of it.
TEST(RefinementTest, AProblemWithoutObservationsIsAFailure) {
  SimulatedDataset data;
  const PipelineResult filtered = FilteredSimulation(&data);
  BundleAdjustmentProblem problem = filtered.problem;
  problem.observations.clear();
  const Refinement refinement = Refine(problem, data.camera, filtered.estimate,
                                       BundleAdjustmentOptions(), DepthAlignmentOptions());
  EXPECT_FALSE(refinement.ok());
  EXPECT_NE(refinement.failure.find("no observations"), std::string::npos) << refinement.failure;
}

TEST(RefinementTest, AStopRequestInterruptsTheSolveAndIsAFailure) {
  SimulatedDataset data;
  const PipelineResult filtered = FilteredSimulation(&data);
  BundleAdjustmentOptions ba;
  int polls = 0;
  ba.stop = [&polls] { return ++polls > 2; };
  const Refinement refinement =
      Refine(filtered.problem, data.camera, filtered.estimate, ba, DepthAlignmentOptions());
  EXPECT_TRUE(refinement.smoothed.interrupted);
  EXPECT_LE(refinement.smoothed.iterations, 2);
  EXPECT_FALSE(refinement.ok());
  EXPECT_NE(refinement.failure.find("interrupted"), std::string::npos) << refinement.failure;
  // Without the request, the same solve is a refinement.
  EXPECT_TRUE(Refine(filtered.problem, data.camera, filtered.estimate, BundleAdjustmentOptions(),
                     DepthAlignmentOptions())
                  .ok());
}

// Asked for, the depth correction is estimated from the check's solve and reported; the
// simulation's ranges have none, so it comes out zero within its sigma, and the calibration it
// makes is the rig's with those coefficients added. The check and the refinement are the
// same solves as without it.
TEST(RefinementTest, EstimatesAndReportsTheDepthCorrectionWhenAsked) {
  SimulatedDataset data;
  const PipelineResult filtered = FilteredSimulation(&data);
  BundleAdjustmentOptions ba;
  ba.estimate_depth_correction = true;
  const Refinement with =
      Refine(filtered.problem, data.camera, filtered.estimate, ba, DepthAlignmentOptions());
  const Refinement without = Refine(filtered.problem, data.camera, filtered.estimate,
                                    BundleAdjustmentOptions(), DepthAlignmentOptions());
  ASSERT_TRUE(with.ok());
  ASSERT_TRUE(with.depth_correction_tried);
  ASSERT_TRUE(with.depth_correction.usable) << with.depth_correction.failure;
  EXPECT_FALSE(without.depth_correction_tried);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::fabs(with.depth_correction.coefficients[i]),
              5.0 * std::sqrt(with.depth_correction.covariance(i, i)))
        << i;
  }
  EXPECT_EQ(with.smoothed.final_cost, without.smoothed.final_cost);
  const std::string json = RefinementToJson(with).Dump();
  EXPECT_NE(json.find("\"depth_correction\""), std::string::npos);
  EXPECT_NE(json.find("\"chi_square_drop\""), std::string::npos);
  EXPECT_EQ(RefinementToJson(without).Dump().find("\"depth_correction\""), std::string::npos);

  Rig rig;
  rig.colour = data.camera;
  rig.range.camera = data.camera;
  rig.registered = true;
  rig.range.noise.a = 0.001;
  rig.range.depth_correction = {0.01, 0.0, 0.0};
  std::vector<std::string> warnings;
  const std::optional<Rig> corrected = CorrectedCalibration(with, rig, &warnings);
  ASSERT_TRUE(corrected.has_value()) << (warnings.empty() ? "" : warnings[0]);
  EXPECT_EQ(corrected->range.depth_correction[0], 0.01 + with.depth_correction.coefficients[0]);
  EXPECT_TRUE(warnings.empty());
  EXPECT_FALSE(CorrectedCalibration(without, rig, &warnings).has_value());
  // An estimate that no calibration can hold is not written, with a warning.
  Refinement absurd = with;
  absurd.depth_correction.coefficients = {-3.0, 0.0, 0.0};
  EXPECT_FALSE(CorrectedCalibration(absurd, rig, &warnings).has_value());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("corrected_calib.yaml"), std::string::npos) << warnings[0];
}

// The position RMSE of `solved`'s poses against the simulation's truth.
double PositionRmse(const BundleAdjustmentResult& solved, const SimulatedDataset& data) {
  double sum = 0.0;
  for (const auto& [frame, T_w_c] : solved.T_w_c) {
    sum +=
        (T_w_c.translation() - PoseToIsometry(data.T_w_c_true[frame]).translation()).squaredNorm();
  }
  return std::sqrt(sum / solved.T_w_c.size());
}

// With a correction planted in the ranges, applying the estimate makes the refinement again
// on the corrected ranges: that is the refinement, nearer the truth than the one on the ranges
// as read, and the report holds both. Not asked for, the refinement is the one as read.
TEST(RefinementTest, AppliesTheEstimatedDepthCorrectionWhenAsked) {
  SimulatedDataset data;
  PipelineResult filtered = FilteredSimulation(&data);
  const std::array<double, 3> planted = {-0.03, 0.02, 0.02};
  for (auto* observations : {&filtered.problem.observations, &filtered.problem.registered}) {
    for (BundleAdjustmentObservation& o : *observations) {
      const Eigen::Vector3d ray = data.camera.Unproject(o.observation.z.head<2>());
      o.observation.z[2] *= DepthCorrectionFactorAt(ray, planted);
    }
  }
  BundleAdjustmentOptions ba;
  ba.estimate_depth_correction = true;
  const Refinement estimated =
      Refine(filtered.problem, data.camera, filtered.estimate, ba, DepthAlignmentOptions());
  ba.apply_depth_correction = true;
  const Refinement applied =
      Refine(filtered.problem, data.camera, filtered.estimate, ba, DepthAlignmentOptions());
  ASSERT_TRUE(estimated.ok() && applied.ok()) << applied.failure;
  EXPECT_EQ(estimated.corrected, nullptr);
  ASSERT_NE(applied.corrected, nullptr);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(applied.depth_correction.coefficients[i], planted[i], 0.01) << i;
  }
  EXPECT_EQ(&applied.refined(), &applied.corrected->refined());
  EXPECT_EQ(&applied.uncorrected_refined(), &applied.features());
  // The refinement as read is the one without the correction applied, to the bit.
  EXPECT_EQ(applied.uncorrected_refined().final_cost, estimated.refined().final_cost);
  const double read = PositionRmse(applied.uncorrected_refined(), data);
  const double corrected = PositionRmse(applied.refined(), data);
  EXPECT_LT(corrected, 0.5 * read) << corrected << " against " << read;
  EXPECT_GT(applied.change_from_uncorrected.translation_m.rmse, 0.0);
  EXPECT_FALSE(applied.corrected->depth_correction_tried);
  const std::string json = RefinementToJson(applied).Dump();
  EXPECT_NE(json.find("\"applied\": true"), std::string::npos);
  EXPECT_NE(json.find("\"change_from_uncorrected_translation_rmse_m\""), std::string::npos);
  EXPECT_NE(RefinementToJson(estimated).Dump().find("\"applied\": false"), std::string::npos);

  // Applying needs the estimate.
  BundleAdjustmentOptions apply_only;
  apply_only.apply_depth_correction = true;
  std::string why;
  EXPECT_FALSE(apply_only.Check(&why));
  EXPECT_NE(why.find("estimate_depth_correction"), std::string::npos) << why;
}

// Given clouds, the depth-aligned solve is the refinement and computes the covariances; the
// features' solve before it leaves its own out. Clouds without a valid point give no pairs,
// so the depth-aligned solve is the features' again, which its result must show.
TEST(RefinementTest, OnlyTheSolveThatIsTheRefinementComputesCovariances) {
  SimulatedDataset data;
  const PipelineResult filtered = FilteredSimulation(&data);
  RangeClouds clouds;
  for (const auto& [frame, T] : filtered.problem.T_w_c) {
    RangeCloud& cloud = clouds.clouds[frame];
    cloud.grid = data.camera;
    const size_t cells = static_cast<size_t>(cloud.grid.width) * cloud.grid.height;
    cloud.p_r.assign(cells, Eigen::Vector3f::Constant(std::nanf("")));
    cloud.n_r = cloud.p_r;
    cloud.sigma_m.assign(cells, 0.0f);
  }
  const Refinement refinement = Refine(filtered.problem, data.camera, filtered.estimate,
                                       BundleAdjustmentOptions(), DepthAlignmentOptions(), &clouds);
  ASSERT_TRUE(refinement.ok()) << refinement.failure;
  ASSERT_TRUE(refinement.depth_alignment_used);
  EXPECT_EQ(refinement.depth_stats.constraints, 0);
  EXPECT_EQ(&refinement.refined(), &refinement.depth_aligned);
  EXPECT_TRUE(refinement.smoothed.pose_covariances.empty());
  EXPECT_TRUE(refinement.smoothed.covariance_error.empty()) << refinement.smoothed.covariance_error;
  ASSERT_EQ(refinement.depth_aligned.pose_covariances.size(), filtered.problem.T_w_c.size());
  // Without clouds the features' solve is the refinement, with its covariances: the same as
  // the depth-aligned solve's above, which solved the same problem from the same start.
  const Refinement features_only = Refine(filtered.problem, data.camera, filtered.estimate,
                                          BundleAdjustmentOptions(), DepthAlignmentOptions());
  ASSERT_EQ(features_only.features().pose_covariances.size(), filtered.problem.T_w_c.size());
  for (const auto& [frame, P] : features_only.features().pose_covariances) {
    EXPECT_TRUE(P.isApprox(refinement.depth_aligned.pose_covariances.at(frame), 1e-3))
        << "frame " << frame;
  }
}

// As if the filter's gate had refused nine right observations and a wrong one: the check's
// solve keeps the filter's observations, the refinement solves with every registered one and
// its rejection rounds judge them (keeping the nine, rejecting the wrong one).
TEST(RefinementTest, TheRefinementWeighsEveryRegisteredObservationTheCheckTheFiltersOwn) {
  SimulatedDataset data;
  const PipelineResult filtered = FilteredSimulation(&data);
  BundleAdjustmentProblem problem = filtered.problem;
  // The ten refused are among the observations the solve keeps without any refusal.
  const BundleAdjustmentResult all = SolveBundleAdjustment(problem, data.camera, {});
  const auto rejected_by_all = [&all](const BundleAdjustmentObservation& o) {
    return std::any_of(all.rejected.begin(), all.rejected.end(), [&o](const auto& r) {
      return r.frame_id == o.frame_id && r.observation.feature_id == o.observation.feature_id;
    });
  };
  problem.registered = problem.observations;
  std::vector<size_t> refused;
  for (size_t i = 0; i < problem.registered.size() && refused.size() < 10; ++i) {
    if (!rejected_by_all(problem.registered[i])) refused.push_back(i);
  }
  ASSERT_EQ(refused.size(), 10u);
  BundleAdjustmentObservation& wrong = problem.registered[refused[3]];
  wrong.observation.z.head<2>() += Eigen::Vector2d(12.0, -9.0);
  problem.observations.clear();
  for (size_t i = 0; i < problem.registered.size(); ++i) {
    if (std::find(refused.begin(), refused.end(), i) == refused.end()) {
      problem.observations.push_back(filtered.problem.observations[i]);
    }
  }

  const Refinement refinement = Refine(problem, data.camera, filtered.estimate,
                                       BundleAdjustmentOptions(), DepthAlignmentOptions());
  ASSERT_TRUE(refinement.ok()) << refinement.failure;
  ASSERT_TRUE(refinement.registered_used);
  EXPECT_EQ(&refinement.refined(), &refinement.registered);
  EXPECT_EQ(refinement.refused, 10);
  EXPECT_EQ(refinement.refused_kept, 9);
  EXPECT_TRUE(
      std::any_of(refinement.registered.rejected.begin(), refinement.registered.rejected.end(),
                  [&wrong](const auto& r) { return r.observation.z == wrong.observation.z; }));
  EXPECT_EQ(refinement.smoothed.observations, static_cast<int>(problem.observations.size()));
  EXPECT_EQ(refinement.registered.observations, static_cast<int>(problem.registered.size()));
  // Only the refinement's solve computes covariances; the comparison is the check's.
  EXPECT_TRUE(refinement.smoothed.pose_covariances.empty());
  EXPECT_EQ(refinement.registered.pose_covariances.size(), problem.T_w_c.size());
  const FilterSmootherComparison check =
      CompareFilterToSmoother(filtered.estimate, SmootherEstimate(refinement.smoothed));
  EXPECT_EQ(refinement.comparison.translation_m.rmse, check.translation_m.rmse);
  const FilterSmootherComparison against_all =
      CompareFilterToSmoother(filtered.estimate, SmootherEstimate(refinement.registered));
  EXPECT_EQ(refinement.registered_comparison.mahalanobis.rmse, against_all.mahalanobis.rmse);
  EXPECT_NE(against_all.mahalanobis.rmse, check.mahalanobis.rmse);
  const std::string json = RefinementToJson(refinement).Dump();
  EXPECT_NE(json.find("\"refused_kept\": 9"), std::string::npos) << json;

  // Switched off, the refinement is the check's solve.
  BundleAdjustmentOptions own;
  own.refine_registered = false;
  const Refinement check_only =
      Refine(problem, data.camera, filtered.estimate, own, DepthAlignmentOptions());
  ASSERT_TRUE(check_only.ok()) << check_only.failure;
  EXPECT_FALSE(check_only.registered_tried);
  EXPECT_EQ(&check_only.refined(), &check_only.smoothed);
  EXPECT_EQ(check_only.smoothed.pose_covariances.size(), problem.T_w_c.size());
  for (const auto& [frame, T] : check_only.smoothed.T_w_c) {
    EXPECT_EQ(T.matrix(), refinement.smoothed.T_w_c.at(frame).matrix()) << "frame " << frame;
  }
}

}  // namespace
}  // namespace ieslam
