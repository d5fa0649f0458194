#include "backend/evaluation/filter_smoother_comparison.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "backend/ba_test_scene.h"
#include "backend/bundle_adjustment.h"
#include "backend/information_filter.h"

namespace ieslam {
namespace {

using testing_ba::MakeTestScene;
using testing_ba::TestScene;

SlamEstimate SmallEstimate() {
  SlamEstimate estimate;
  for (int k = 0; k < 4; ++k) {
    Vector6d pose;
    pose << 0.3 * k, 0.1, -0.2, 0.1 * k, 0.05, -3.1;  // gamma near -pi: wrapping matters
    estimate.poses[k] = pose;
    estimate.pose_covariances[k] = Matrix6d::Identity() * 1e-4;
  }
  estimate.features[7] = Eigen::Vector3d(1, 2, 3);
  estimate.features[8] = Eigen::Vector3d(-1, 0, 5);
  return estimate;
}

TEST(FilterSmootherComparisonTest, IdenticalEstimatesGiveZeroDifference) {
  const SlamEstimate estimate = SmallEstimate();
  const FilterSmootherComparison c = CompareFilterToSmoother(estimate, estimate);
  ASSERT_EQ(c.frames.size(), 4u);
  EXPECT_EQ(c.translation_m.max, 0.0);
  EXPECT_LT(c.rotation_deg.max, 1e-6);
  EXPECT_EQ(c.mahalanobis.max, 0.0);
  EXPECT_EQ(c.feature_m.count, 2u);
  EXPECT_EQ(c.feature_m.max, 0.0);
  EXPECT_EQ(c.frames_only_in_filter, 0);
}

TEST(FilterSmootherComparisonTest, KnownOffsetsGiveKnownDistances) {
  const SlamEstimate filter = SmallEstimate();
  SlamEstimate smoother = filter;
  smoother.poses[1][0] += 0.03;        // 3 sigma in x
  smoother.poses[2][5] = M_PI - 0.01;  // gamma -3.1 -> pi - 0.01: 0.0316 rad across pi
  smoother.poses.erase(3);
  smoother.poses[9] = Vector6d::Zero();
  smoother.features[7].x() += 0.5;
  const FilterSmootherComparison c = CompareFilterToSmoother(filter, smoother);
  ASSERT_EQ(c.frames.size(), 3u);
  EXPECT_EQ(c.frames_only_in_filter, 1);
  EXPECT_EQ(c.frames_only_in_smoother, 1);
  EXPECT_NEAR(c.frames[1].translation_m, 0.03, 1e-12);
  EXPECT_NEAR(c.frames[1].mahalanobis, 3.0, 1e-9);
  const double wrapped = -3.1 - (M_PI - 0.01) + 2 * M_PI;
  EXPECT_NEAR(c.frames[2].difference[5], wrapped, 1e-12);
  EXPECT_NEAR(c.frames[2].rotation_deg, std::abs(wrapped) * 180 / M_PI, 1e-6);
  EXPECT_NEAR(c.frames[2].mahalanobis, std::abs(wrapped) / 0.01, 1e-6);
  EXPECT_NEAR(c.translation_m.max, 0.03, 1e-12);
  EXPECT_NEAR(c.translation_m.rmse, 0.03 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(c.feature_m.max, 0.5, 1e-12);

  const std::string json = ComparisonToJson(c).Dump();
  for (const char* key : {"\"translation_m\"", "\"rotation_deg\"", "\"mahalanobis\"", "\"rmse\"",
                          "\"frames\"", "\"frame_id\": 2"}) {
    EXPECT_NE(json.find(key), std::string::npos) << key << " in " << json;
  }
  EXPECT_EQ(ComparisonToJson(c, false).Dump().find("\"frames\""), std::string::npos);
}

// Without the filter's covariances there is no Mahalanobis distance: its figures are null,
// not a 0 that reads as agreement.
TEST(FilterSmootherComparisonTest, NoCovariancesGiveNullMahalanobisFigures) {
  SlamEstimate filter = SmallEstimate();
  filter.pose_covariances.clear();
  const FilterSmootherComparison c = CompareFilterToSmoother(filter, SmallEstimate());
  EXPECT_EQ(c.mahalanobis.count, 0u);
  const std::string json = ComparisonToJson(c, false).Dump();
  const size_t at = json.find("\"mahalanobis\"");
  ASSERT_NE(at, std::string::npos) << json;
  const std::string figures = json.substr(at, json.find('}', at) - at);
  EXPECT_NE(figures.find("\"rmse\": null"), std::string::npos) << figures;
  EXPECT_EQ(figures.find("\"rmse\": 0"), std::string::npos) << figures;
}

// Runs the filter over a scene's frames in order, each pose initialised at `initial`.
void RunFilter(const TestScene& scene, const std::map<int, std::vector<FeatureObservation>>& obs,
               const std::map<int, Vector6d>& initial, InformationFilter* filter) {
  for (const auto& [frame_id, pose] : scene.poses) {
    if (frame_id == scene.poses.begin()->first) {
      filter->AddFirstPose(frame_id, initial.at(frame_id), obs.at(frame_id));
    } else {
      filter->AddPose(frame_id, initial.at(frame_id), obs.at(frame_id));
    }
  }
}

// Noise-free observations, the filter linearised at the truth: both estimators solve the
// same problem at the same point, so their estimates and their pose covariances (the
// bundle adjustment's carried from the quaternion tangent to the Euler 6-vector) agree.
TEST(FilterSmootherComparisonTest, FilterAndBundleAdjustmentAgreeOnExactData) {
  std::mt19937 rng(11);
  const TestScene scene = MakeTestScene(6, 60, &rng);
  InformationFilter filter(InformationFilterOptions(), scene.camera);
  RunFilter(scene, scene.observations, scene.poses, &filter);

  const BundleAdjustmentProblem problem = MakeProblemFromFilter(filter, scene.observations);
  EXPECT_EQ(problem.AnchorFrameId(), scene.poses.begin()->first);
  BundleAdjustmentOptions options;
  options.compute_covariances = true;
  const BundleAdjustmentResult ba = SolveBundleAdjustment(problem, scene.camera, options);
  ASSERT_TRUE(ba.usable) << ba.termination;
  EXPECT_LT(ba.final_cost, 1e-12);

  const FilterSmootherComparison c =
      CompareFilterToSmoother(FilterEstimate(filter), SmootherEstimate(ba));
  ASSERT_EQ(c.frames.size(), scene.poses.size());
  EXPECT_LT(c.translation_m.max, 1e-7);
  EXPECT_LT(c.rotation_deg.max, 1e-6);
  EXPECT_LT(c.mahalanobis.max, 1e-2);
  EXPECT_LT(c.feature_m.max, 1e-7);
  for (const auto& [frame_id, P_ba] : ba.pose_covariances_euler) {
    if (frame_id == scene.poses.begin()->first) continue;
    const Matrix6d P_filter = filter.PoseCovariance(frame_id);
    EXPECT_LT((P_ba - P_filter).norm(), 1e-3 * P_filter.norm()) << "frame " << frame_id << "\nBA:\n"
                                                                << P_ba << "\nfilter:\n"
                                                                << P_filter;
  }
}

// With noise the filter's once-linearised estimate and the smoother's differ, but by much
// less than the filter's own uncertainty, and the smoother's cost is the lower.
TEST(FilterSmootherComparisonTest, NoisyFilterLiesWithinItsCovarianceOfTheSmoother) {
  std::mt19937 rng(12);
  const TestScene scene = MakeTestScene(6, 60, &rng);
  const BundleAdjustmentProblem noisy = testing_ba::MakeTestProblem(scene, 0, 0, 0, true, &rng);
  std::map<int, std::vector<FeatureObservation>> observations;
  for (const BundleAdjustmentObservation& o : noisy.observations) {
    observations[o.frame_id].push_back(o.observation);
  }
  std::map<int, Vector6d> initial = scene.poses;
  std::normal_distribution<double> gauss;
  for (auto& [frame_id, pose] : initial) {
    if (frame_id == scene.poses.begin()->first) continue;
    for (int i = 0; i < 6; ++i) pose[i] += 0.005 * gauss(rng);
  }
  InformationFilter filter(InformationFilterOptions(), scene.camera);
  RunFilter(scene, observations, initial, &filter);

  const BundleAdjustmentResult ba = SolveBundleAdjustment(
      MakeProblemFromFilter(filter, observations), scene.camera, BundleAdjustmentOptions());
  ASSERT_TRUE(ba.usable) << ba.termination;
  EXPECT_LE(ba.final_cost, ba.initial_cost);
  const FilterSmootherComparison c =
      CompareFilterToSmoother(FilterEstimate(filter), SmootherEstimate(ba));
  EXPECT_GT(c.translation_m.max, 0.0);
  EXPECT_LT(c.mahalanobis.max, 3.0);
  EXPECT_EQ(c.frames.front().frame_id, scene.poses.begin()->first);
  EXPECT_EQ(c.frames.front().translation_m, 0.0);  // the anchor is the filter's own
}

}  // namespace
}  // namespace ieslam
