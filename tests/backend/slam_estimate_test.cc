#include "backend/slam_estimate.h"

#include <random>

#include <gtest/gtest.h>

#include "ba_test_scene.h"
#include "backend/bundle_adjustment.h"
#include "backend/information_filter.h"

namespace ieslam {
namespace {

TEST(SlamEstimateTest, TheFiltersEstimateIsItsStateAndItsMarginals) {
  std::mt19937 rng(3);
  const testing_ba::TestScene scene = testing_ba::MakeTestScene(4, 40, &rng);
  InformationFilter filter(InformationFilterOptions(), scene.camera);
  for (const auto& [frame, pose] : scene.poses) {
    if (filter.num_poses() == 0) {
      filter.AddFirstPose(frame, pose, scene.observations.at(frame));
    } else {
      filter.AddPose(frame, pose, scene.observations.at(frame));
    }
  }
  const SlamEstimate estimate = FilterEstimate(filter);
  ASSERT_EQ(estimate.poses.size(), 4u);
  ASSERT_EQ(estimate.pose_covariances.size(), 4u);
  EXPECT_EQ(static_cast<int>(estimate.features.size()), filter.num_features());
  for (const auto& [frame, pose] : estimate.poses) {
    EXPECT_EQ(pose, filter.pose(frame));
    EXPECT_EQ(estimate.pose_covariances.at(frame), filter.PoseCovariance(frame));
  }
  for (const auto& [id, p_w] : estimate.features) EXPECT_EQ(p_w, filter.feature(id));
  EXPECT_TRUE(FilterEstimate(filter, /*with_covariances=*/false).pose_covariances.empty());
}

TEST(SlamEstimateTest, TheSmoothersEstimateIsItsResult) {
  BundleAdjustmentResult result;
  result.poses[3] = Vector6d::Constant(0.5);
  result.pose_covariances_euler[3] = Matrix6d::Identity();
  result.p_w[7] = Eigen::Vector3d(1, 2, 3);
  const SlamEstimate estimate = SmootherEstimate(result);
  EXPECT_EQ(estimate.poses, result.poses);
  EXPECT_EQ(estimate.pose_covariances, result.pose_covariances_euler);
  EXPECT_EQ(estimate.features, result.p_w);
}

}  // namespace
}  // namespace ieslam
