#include "backend/depth_correction.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "backend/ba_test_scene.h"
#include "backend/bundle_adjustment.h"
#include "core/kinect_range_imager.h"
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

// The observations corrected by the planted coefficients are those of a range imager without
// the correction: exactly where the imager sits at the colour camera (a point moved along its
// ray keeps its normalised coordinates); where it does not, up to the product of the
// correction and the offset (the read point is placed in the range imager off its true place).
TEST(DepthCorrectionTest, CorrectedObservationsHaveTheTrueRanges) {
  std::mt19937 rng(13);
  const TestScene scene = MakeTestScene(8, 150, &rng);
  const std::array<double, 3> planted = {-0.03, 0.02, 0.02};
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.linear() = Eigen::AngleAxisd(0.15, Eigen::Vector3d::UnitY()).toRotationMatrix();
  offset.translation() = Eigen::Vector3d(0.025, 0.0, 0.0);
  for (const Eigen::Isometry3d& T_colour_range : {Eigen::Isometry3d::Identity(), offset}) {
    BundleAdjustmentProblem read = WithPlantedCorrection(
        scene, MakeTestProblem(scene, 0.0, 0.0, 0.0, false, &rng), planted, T_colour_range);
    read.registered = read.observations;
    const BundleAdjustmentProblem corrected =
        WithRangesCorrected(read, scene.camera, T_colour_range, planted);
    ASSERT_EQ(corrected.observations.size(), read.observations.size());
    ASSERT_EQ(corrected.registered.size(), read.registered.size());
    const bool exact = T_colour_range.isApprox(Eigen::Isometry3d::Identity());
    double worst = 0.0, worst_read = 0.0;
    for (const auto* observations : {&corrected.observations, &corrected.registered}) {
      for (size_t i = 0; i < observations->size(); ++i) {
        const BundleAdjustmentObservation& o = (*observations)[i];
        const BundleAdjustmentObservation& r = read.observations[i];
        const double range =
            WorldToCamera(scene.poses.at(o.frame_id), scene.points.at(o.observation.feature_id))
                .norm();
        worst = std::max(worst, std::abs(o.observation.z[2] - range));
        worst_read = std::max(worst_read, std::abs(r.observation.z[2] - range));
        EXPECT_EQ(o.observation.z.head<2>(), r.observation.z.head<2>());
        // The reading's noise is divided with it.
        const double factor = r.observation.z[2] / o.observation.z[2];
        EXPECT_NEAR(o.observation.Q(2, 2), r.observation.Q(2, 2) / (factor * factor), 1e-15);
        EXPECT_NEAR(o.observation.Q(0, 2), r.observation.Q(0, 2) / factor, 1e-15);
        EXPECT_EQ(o.observation.Q(0, 0), r.observation.Q(0, 0));
      }
    }
    EXPECT_GT(worst_read, 0.01);  // centimetres read wrong
    EXPECT_LT(worst, exact ? 1e-12 : 0.01 * worst_read) << exact;
    if (exact) {
      EXPECT_LT(SolveBundleAdjustment(corrected, scene.camera, Options()).final_cost, 1e-12);
    }
  }
}

// A correction is applied only within what a calibration allows: each coefficient, and the
// factor at every observation.
TEST(DepthCorrectionTest, ACorrectionNoCalibrationAllowsIsRefused) {
  std::mt19937 rng(17);
  const TestScene scene = MakeTestScene(4, 50, &rng);
  BundleAdjustmentProblem problem = MakeTestProblem(scene, 0.0, 0.0, 0.0, false, &rng);
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  EXPECT_EQ(DepthCorrectionRefused(problem, scene.camera, I, {-0.03, 0.02, 0.02}), "");
  EXPECT_NE(DepthCorrectionRefused(problem, scene.camera, I, {0.51, 0.0, 0.0}).find("0.51"),
            std::string::npos);
  // Within the coefficients' bound, a factor above 2 at a point seen far off the axis.
  problem.registered = problem.observations;
  BundleAdjustmentObservation& far = problem.registered.back();
  far.observation.z.head<2>() = Eigen::Vector2d(scene.camera.cx + 2.5 * scene.camera.fx,
                                                scene.camera.cy + 2.5 * scene.camera.fy);
  const std::string why = DepthCorrectionRefused(problem, scene.camera, I, {0.0, 0.0, 0.5});
  EXPECT_NE(why.find("frame " + std::to_string(far.frame_id)), std::string::npos) << why;
}

// The largest distances between two clouds' points and between their normals, over the
// cells valid in both.
struct CloudDifference {
  double points = 0.0;
  double normals = 0.0;
};

CloudDifference Difference(const RangeCloud& a, const RangeCloud& b) {
  CloudDifference d;
  for (int i = 0; i < static_cast<int>(a.p_r.size()); ++i) {
    if (!a.Valid(i) || !b.Valid(i)) continue;
    d.points = std::max(d.points, static_cast<double>((a.p_r[i] - b.p_r[i]).norm()));
    d.normals = std::max(d.normals, static_cast<double>((a.n_r[i] - b.n_r[i]).norm()));
  }
  return d;
}

// A plane read through a tilted, bowl-shaped correction is a bent surface; the corrected cloud
// is the plane's again: its points and normals, each point on its own ray, and the sigmas the
// reading's divided.
TEST(DepthCorrectionTest, ACorrectedCloudIsTheSurfaceAsItIs) {
  const RangeImager range = testing_core::KinectRangeImager();
  const std::array<double, 3> correction = {-0.03, 0.02, 0.02};
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.1, -1.0).normalized();  // faces the camera
  const auto cloud = [&](const std::array<double, 3>& read_with) {
    return MakeRangeCloud(testing_core::PlaneDepth(range, n, -2.0, read_with), range,
                          Eigen::Isometry3d::Identity(), RangeCloudOptions(), "plane");
  };
  const RangeCloud truth = cloud({0.0, 0.0, 0.0});
  const RangeCloud read = cloud(correction);
  const RangeCloud corrected = WithRangesCorrected(read, correction);
  ASSERT_EQ(corrected.ValidCount(), read.ValidCount());
  ASSERT_GT(read.ValidCount(), 10000);
  for (int i = 0; i < static_cast<int>(read.p_r.size()); ++i) {
    if (!read.Valid(i)) continue;
    const Eigen::Vector3d p = corrected.p_r[i].cast<double>();
    EXPECT_LT(p.normalized().cross(read.p_r[i].cast<double>().normalized()).norm(), 1e-6);
    const double factor = read.p_r[i].norm() / p.norm();
    EXPECT_NEAR(corrected.sigma_m[i], read.sigma_m[i] / factor, 1e-6 * read.sigma_m[i]);
  }
  const CloudDifference before = Difference(read, truth), after = Difference(corrected, truth);
  EXPECT_GT(before.points, 0.02);
  EXPECT_LT(after.points, 2e-5);  // float points
  EXPECT_GT(before.normals, 0.02);
  // The read normals are the fitted planes of a bent surface, turned as its points are: the
  // window's curvature leaves a few 1e-4.
  EXPECT_LT(after.normals, 1e-3);
}

// A rolling shutter's points are corrected in the frame of the row that read them: a wall seen
// turning, read through a correction, becomes the cloud of the true depth again (whose normals,
// fitted to the rows' sheared points, are a few degrees off the wall's).
TEST(DepthCorrectionTest, ARollingShuttersCloudIsCorrectedRowByRow) {
  const RangeImager range = testing_core::KinectRangeImager();
  const std::array<double, 3> correction = {0.04, -0.02, 0.01};
  const RangeRowMotion motion = testing_core::TurningRowMotion(range, 1.5, 0.03);
  // The wall z = 2 of the frame's pose as each row sees it, and as the imager reads it.
  cv::Mat depth(range.camera.height, range.camera.width, CV_32FC1);
  cv::Mat depth_read = depth.clone();
  for (int y = 0; y < depth.rows; ++y) {
    const Eigen::Vector3d n_row = motion(y).linear().transpose() * Eigen::Vector3d::UnitZ();
    for (int x = 0; x < depth.cols; ++x) {
      const Eigen::Vector3d ray = range.camera.Unproject(Eigen::Vector2d(x, y));
      depth.at<float>(y, x) = static_cast<float>(2.0 / n_row.dot(ray));
      depth_read.at<float>(y, x) =
          static_cast<float>(depth.at<float>(y, x) * DepthCorrectionFactorAt(ray, correction));
    }
  }
  const RangeCloud truth = MakeRangeCloud(depth, range, Eigen::Isometry3d::Identity(),
                                          RangeCloudOptions(), "wall", nullptr, motion);
  const RangeCloud read = MakeRangeCloud(depth_read, range, Eigen::Isometry3d::Identity(),
                                         RangeCloudOptions(), "wall", nullptr, motion);
  ASSERT_GT(read.ValidCount(), 10000);
  const CloudDifference before = Difference(read, truth);
  const CloudDifference after = Difference(WithRangesCorrected(read, correction), truth);
  EXPECT_GT(before.points, 0.02);
  EXPECT_LT(after.points, 2e-5);
  EXPECT_GT(before.normals, 0.02);
  EXPECT_LT(after.normals, 1e-3);
}

// A correction whose factor leaves what a calibration allows somewhere leaves those points out.
TEST(DepthCorrectionTest, PointsWhereTheFactorIsNoCalibrationAreLeftOut) {
  const RangeImager range = testing_core::KinectRangeImager();
  const Eigen::Vector3d n(0.0, 0.0, -1.0);
  const RangeCloud read =
      MakeRangeCloud(testing_core::PlaneDepth(range, n, -2.0, {0.0, 0.0, 0.0}), range,
                     Eigen::Isometry3d::Identity(), RangeCloudOptions(), "wall");
  // Factor 1 + 2 x: below 0.5 left of x = -0.25, above 2 right of x = 0.5 (the image spans
  // x within +-0.55).
  const RangeCloud corrected = WithRangesCorrected(read, {2.0, 0.0, 0.0});
  int kept = 0;
  for (int i = 0; i < static_cast<int>(read.p_r.size()); ++i) {
    if (!read.Valid(i)) continue;
    const double x = read.p_r[i].x() / read.p_r[i].z();
    const bool allowed = x > -0.25 + 1e-6 && x < 0.5 - 1e-6;
    if (x > -0.25 - 1e-6 && x < -0.25 + 1e-6) continue;  // at the bound
    if (x > 0.5 - 1e-6 && x < 0.5 + 1e-6) continue;
    EXPECT_EQ(corrected.Valid(i), allowed) << x;
    kept += corrected.Valid(i);
  }
  EXPECT_GT(kept, 1000);
  EXPECT_LT(kept, read.ValidCount());
}

}  // namespace
}  // namespace ieslam
