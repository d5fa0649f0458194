#include "backend/depth_correction.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "backend/ba_test_scene.h"
#include "backend/bundle_adjustment.h"
#include "core/pose.h"

namespace ieslam {
namespace {

using testing_ba::MakeTestProblem;
using testing_ba::MakeTestScene;
using testing_ba::TestScene;

// The scene's observations with each range read as the imager at T_colour_range with
// `correction` would read it: the true range times the factor at the point's place in the
// range image.
BundleAdjustmentProblem WithPlantedCorrection(const TestScene& scene,
                                              BundleAdjustmentProblem problem,
                                              const std::array<double, 3>& correction,
                                              const Eigen::Isometry3d& T_colour_range) {
  RangeImager range;
  range.depth_correction = correction;
  for (BundleAdjustmentObservation& o : problem.observations) {
    const Eigen::Vector3d p_c =
        WorldToCamera(scene.poses.at(o.frame_id), scene.points.at(o.observation.feature_id));
    const Eigen::Vector3d p_r = T_colour_range.inverse() * p_c;
    o.observation.z[2] +=
        p_c.norm() * (range.DepthCorrectionFactor(p_r.x() / p_r.z(), p_r.y() / p_r.z()) - 1.0);
  }
  return problem;
}

BundleAdjustmentOptions Options() {
  BundleAdjustmentOptions ba;
  ba.rejection_chi2 = 0.0;  // exact data: nothing to reject
  ba.compute_covariances = false;
  return ba;
}

// On exact observations of a planted correction the bundle adjustment without one is biased;
// the estimate finds the correction and leaves nothing of the cost.
TEST(DepthCorrectionTest, FindsAPlantedCorrectionOnExactData) {
  std::mt19937 rng(7);
  const TestScene scene = MakeTestScene(8, 150, &rng);
  const std::array<double, 3> planted = {-0.02, 0.01, 0.015};
  const BundleAdjustmentProblem problem =
      WithPlantedCorrection(scene, MakeTestProblem(scene, 0.02, 0.01, 0.05, false, &rng), planted,
                            Eigen::Isometry3d::Identity());
  const BundleAdjustmentResult solved = SolveBundleAdjustment(problem, scene.camera, Options());
  ASSERT_TRUE(solved.usable);
  EXPECT_GT(solved.final_cost, 1.0);  // the correction is not a pose's or a feature's
  const DepthCorrectionEstimate estimate = EstimateDepthCorrection(
      problem, solved, scene.camera, Eigen::Isometry3d::Identity(), Options());
  ASSERT_TRUE(estimate.usable) << estimate.failure;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(estimate.coefficients[i], planted[i], 1e-6) << i;
  EXPECT_LT(estimate.cost_with, 1e-8);
  EXPECT_NEAR(estimate.cost_without, solved.final_cost, 1e-9 * solved.final_cost);
  EXPECT_EQ(estimate.observations, static_cast<int>(problem.observations.size()));
  EXPECT_GT(estimate.covariance.determinant(), 0.0);
  EXPECT_TRUE(estimate.covariance.isApprox(estimate.covariance.transpose(), 1e-12));

  // Applied on top of a calibration's own, the factors multiply (to first order).
  RangeImager range;
  range.depth_correction = {0.01, 0.0, -0.005};
  const RangeImager corrected = WithDepthCorrection(range, estimate);
  EXPECT_NEAR(corrected.depth_correction[0], 0.01 + planted[0], 1e-6);
  EXPECT_NEAR(corrected.depth_correction[2], -0.005 + planted[2], 1e-6);
}

// Where the range imager sits off the colour camera the factor is taken at the point's place
// in the range image: the right extrinsics find the planted correction exactly, the identity
// does not.
TEST(DepthCorrectionTest, TakesTheFactorInTheRangeImagersFrame) {
  std::mt19937 rng(11);
  const TestScene scene = MakeTestScene(8, 150, &rng);
  Eigen::Isometry3d T_colour_range = Eigen::Isometry3d::Identity();
  T_colour_range.linear() = Eigen::AngleAxisd(0.15, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T_colour_range.translation() = Eigen::Vector3d(0.025, 0.0, 0.0);
  const std::array<double, 3> planted = {0.03, -0.02, 0.0};
  const BundleAdjustmentProblem problem = WithPlantedCorrection(
      scene, MakeTestProblem(scene, 0.0, 0.0, 0.0, false, &rng), planted, T_colour_range);
  const BundleAdjustmentResult solved = SolveBundleAdjustment(problem, scene.camera, Options());
  ASSERT_TRUE(solved.usable);
  const DepthCorrectionEstimate right =
      EstimateDepthCorrection(problem, solved, scene.camera, T_colour_range, Options());
  const DepthCorrectionEstimate wrong = EstimateDepthCorrection(
      problem, solved, scene.camera, Eigen::Isometry3d::Identity(), Options());
  ASSERT_TRUE(right.usable && wrong.usable);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(right.coefficients[i], planted[i], 1e-6) << i;
  EXPECT_LT(right.cost_with, 1e-8);
  EXPECT_GT(wrong.cost_with, 1e-4);
}

// Without a correction in noisy data the estimate is zero within its stated sigma, and the
// stated covariance matches the coefficients' spread over repeated draws of the noise.
TEST(DepthCorrectionTest, NoCorrectionGivesZeroWithinTheStatedSigma) {
  std::mt19937 rng(3);
  const TestScene scene = MakeTestScene(8, 150, &rng);
  Eigen::Vector3d sum_squared_z = Eigen::Vector3d::Zero();
  const int trials = 30;
  for (int trial = 0; trial < trials; ++trial) {
    const BundleAdjustmentProblem problem = MakeTestProblem(scene, 0.0, 0.0, 0.0, true, &rng);
    const BundleAdjustmentResult solved = SolveBundleAdjustment(problem, scene.camera, Options());
    ASSERT_TRUE(solved.usable);
    const DepthCorrectionEstimate estimate = EstimateDepthCorrection(
        problem, solved, scene.camera, Eigen::Isometry3d::Identity(), Options());
    ASSERT_TRUE(estimate.usable) << estimate.failure;
    for (int i = 0; i < 3; ++i) {
      const double z = estimate.coefficients[i] / std::sqrt(estimate.covariance(i, i));
      EXPECT_LT(std::fabs(z), 4.5) << trial << " " << i;
      sum_squared_z[i] += z * z;
    }
    // Three more parameters take about three units of chi-square, never a negative amount.
    EXPECT_GE(estimate.cost_without - estimate.cost_with, -1e-9);
  }
  // Mean squared z ~ 1 when the covariance is right: chi-square(30)/30 lies in [0.53, 1.57]
  // with probability 0.99.
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(sum_squared_z[i] / trials, 0.45) << i;
    EXPECT_LT(sum_squared_z[i] / trials, 1.7) << i;
  }
}

// A problem whose observations are all rejected (or empty) has nothing to estimate from.
TEST(DepthCorrectionTest, NoObservationsIsAFailureNotACrash) {
  std::mt19937 rng(5);
  const TestScene scene = MakeTestScene(3, 20, &rng);
  BundleAdjustmentProblem problem = MakeTestProblem(scene, 0.0, 0.0, 0.0, false, &rng);
  const BundleAdjustmentResult solved = SolveBundleAdjustment(problem, scene.camera, Options());
  problem.observations.clear();
  const DepthCorrectionEstimate estimate = EstimateDepthCorrection(
      problem, solved, scene.camera, Eigen::Isometry3d::Identity(), Options());
  EXPECT_FALSE(estimate.usable);
  EXPECT_FALSE(estimate.failure.empty());
  EXPECT_EQ(estimate.observations, 0);
}

}  // namespace
}  // namespace ieslam
