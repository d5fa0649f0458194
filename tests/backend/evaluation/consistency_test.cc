#include "backend/evaluation/consistency.h"

#include <map>
#include <random>

#include <gtest/gtest.h>

#include "backend/dense_reference_filter.h"
#include "backend/filter_test_scene.h"
#include "backend/information_filter.h"
#include "backend/observation_gate.h"

namespace ieslam {
namespace {

TEST(ConsistencyTest, NeesBandForTwentyRunsOfAPose) {
  const auto [lo, hi] = NeesBand(6, 20);
  EXPECT_NEAR(lo, 91.573 / 20, 0.01);
  EXPECT_NEAR(hi, 152.211 / 20, 0.01);
  EXPECT_LT(lo, 6.0);
  EXPECT_GT(hi, 6.0);
}

TEST(ConsistencyTest, NeesOfSamplesFromTheCovarianceAveragesTheDimension) {
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss;
  Matrix6d L = Matrix6d::Zero();
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j <= i; ++j) L(i, j) = i == j ? 0.1 + 0.02 * i : 0.01;
  }
  const Matrix6d P = L * L.transpose();
  const Vector6d truth = (Vector6d() << 1, 2, 3, 0.1, 0.2, 0.3).finished();
  double sum = 0.0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    Vector6d w;
    for (int i = 0; i < 6; ++i) w[i] = gauss(rng);
    sum += PoseNees(truth + L * w, truth, P);
  }
  EXPECT_NEAR(sum / n, 6.0, 0.1);
  // An estimate off by twice its sigma in one axis.
  Vector6d off = truth;
  off[0] += 2.0 * std::sqrt(P(0, 0));
  EXPECT_GT(PoseNees(off, truth, P), 3.9);
}

// Errors drawn from the stated covariance: ~95% inside 2 sigma, mean NEES ~6 in its band;
// the same errors against covariances ten times too small: few inside, NEES ~600.
TEST(ConsistencyTest, RightCovariancesCoverTheErrorsAndOverconfidentOnesDoNot) {
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss;
  const Vector6d sigma = (Vector6d() << 0.01, 0.02, 0.015, 0.002, 0.003, 0.001).finished();
  const Matrix6d P = sigma.cwiseAbs2().asDiagonal();
  std::map<int, Vector6d> estimates, truth;
  std::map<int, Matrix6d> right, overconfident;
  for (int k = 0; k < 2000; ++k) {
    truth[k] = (Vector6d() << 0.1 * k, 1, 2, 0.1, 0.2, 0.3).finished();
    Vector6d e;
    for (int i = 0; i < 6; ++i) e[i] = sigma[i] * gauss(rng);
    estimates[k] = truth[k] + e;
    right[k] = P;
    overconfident[k] = P / 100.0;
  }
  right.erase(7);  // a pose without a covariance is left out
  const PoseConsistency good = EvaluatePoseConsistency(estimates, right, truth);
  EXPECT_EQ(good.poses, 1999);
  EXPECT_NEAR(good.inside_2sigma, 0.954, 0.01);
  for (const double share : good.inside_2sigma_per_axis) EXPECT_NEAR(share, 0.954, 0.015);
  EXPECT_NEAR(good.median_error_over_sigma, 0.674, 0.03);
  EXPECT_GT(good.mean_nees, good.nees_band.first);
  EXPECT_LT(good.mean_nees, good.nees_band.second);
  EXPECT_GT(good.mean_rotation_nees, good.rotation_nees_band.first);
  EXPECT_LT(good.mean_rotation_nees, good.rotation_nees_band.second);
  const PoseConsistency bad = EvaluatePoseConsistency(estimates, overconfident, truth);
  EXPECT_LT(bad.inside_2sigma, 0.25);
  EXPECT_GT(bad.mean_nees, 100.0 * bad.nees_band.second / 2.0);
  EXPECT_NEAR(bad.median_error_over_sigma, 6.74, 0.3);
  EXPECT_GT(bad.mean_rotation_nees, 50.0 * bad.rotation_nees_band.second);
}

// Near beta = 90 deg, alpha and gamma turn about nearly the same axis: errors of +0.2 rad in
// both are a rotation of about 0.57 deg, which the rotation error reports.
TEST(ConsistencyTest, RotationErrorIsFreeOfTheEulerCoupling) {
  const Vector6d truth = (Vector6d() << 0, 0, 0, 0.3, M_PI / 2 - 0.05, 0.1).finished();
  const Vector6d estimate = (Vector6d() << 0, 0, 0, 0.5, M_PI / 2 - 0.05, 0.3).finished();
  const Matrix6d P = Vector6d::Constant(0.01 * 0.01).asDiagonal();
  const PoseConsistency c = EvaluatePoseConsistency({{1, estimate}}, {{1, P}}, {{1, truth}});
  ASSERT_EQ(c.per_pose.size(), 1u);
  EXPECT_NEAR(c.per_pose[0].error[3], 0.2, 1e-12);
  EXPECT_NEAR(c.per_pose[0].rotation_error_deg, 0.572, 0.005);
  EXPECT_NEAR(c.median_rotation_error_deg, 0.572, 0.005);
}

// A fixed origin (zero covariance) and a pose without ground truth are not compared.
TEST(ConsistencyTest, TheAnchorAndPosesWithoutTruthAreLeftOut) {
  const std::map<int, Vector6d> estimates = {{0, Vector6d::Zero()}, {1, Vector6d::Ones()}};
  const std::map<int, Matrix6d> covariances = {{0, Matrix6d::Zero()}, {1, Matrix6d::Identity()}};
  EXPECT_EQ(EvaluatePoseConsistency(estimates, covariances, {{0, Vector6d::Zero()}}).poses, 0);
  const PoseConsistency one = EvaluatePoseConsistency(
      estimates, covariances, {{0, Vector6d::Zero()}, {1, Vector6d::Ones()}});
  EXPECT_EQ(one.poses, 1);
  ASSERT_EQ(one.per_pose.size(), 1u);
  EXPECT_EQ(one.per_pose[0].frame, 1);
  EXPECT_EQ(one.per_pose[0].sigma, Vector6d::Ones());
  EXPECT_EQ(one.mean_nees, 0.0);
  EXPECT_EQ(one.inside_2sigma, 1.0);
}

// The ground truth in another world frame comes out in the estimate's, through the earliest
// frame, with the poses between its samples interpolated.
TEST(ConsistencyTest, TruthIsExpressedInTheEstimateFrameThroughTheFirstFrame) {
  Eigen::Isometry3d T_gt_est = Eigen::Isometry3d::Identity();
  T_gt_est.linear() = EulerZyxToRotation(Eigen::Vector3d(0.3, -0.2, 0.1));
  T_gt_est.translation() = Eigen::Vector3d(1, -2, 0.5);
  const auto truth_at = [](double t) {
    return (Vector6d() << 0.1 * t, 0.02 * t, 0.0, 0.05 * t, 0.0, -0.01 * t).finished();
  };
  Trajectory gt;
  for (int k = 0; k <= 100; ++k) {
    const double t = 0.01 * k;
    gt.push_back({t, T_gt_est * PoseToIsometry(truth_at(t))});
  }
  // Frames 5 and 3 in the estimate: the earlier one, 3, is the anchor whatever its id.
  const std::map<int, double> stamps = {{3, 0.105}, {5, 0.505}, {8, 2.0}};
  const std::map<int, Vector6d> estimates = {
      {5, truth_at(0.505)}, {3, truth_at(0.105)}, {8, Vector6d::Zero()}};
  const std::map<int, Vector6d> truth = TruthInEstimateFrame(gt, stamps, estimates, 0.04);
  // Frame 8 lies after the ground truth ends; the anchor's truth would be its estimate.
  ASSERT_EQ(truth.size(), 1u);
  // Linear motion, so interpolation is exact up to the rotation's slerp path.
  EXPECT_LT(PoseDifference(truth.at(5), truth_at(0.505)).norm(), 1e-6);
  // Without ground truth at the anchor nothing can be expressed in the estimate's frame.
  const std::map<int, Vector6d> two = {{3, Vector6d::Zero()}, {5, Vector6d::Zero()}};
  EXPECT_TRUE(TruthInEstimateFrame(gt, {{3, -1.0}, {5, 0.5}}, two, 0.04).empty());
}

// Monte-Carlo runs of a small scene: the filter's pose NEES against the truth equals the dense
// reference EIF's (the same estimate and covariance, computed plainly) in every run, and its
// average over the runs lies in the chi-square band; with the observation gate on too, which
// on exact models drops about one observation in a thousand and keeps the NEES in band.
TEST(ConsistencyTest, FilterNeesMatchesTheDenseReferenceAndLiesInTheBand) {
  constexpr int kRuns = 40;
  for (const double gate : {0.0, 16.27}) {
    SCOPED_TRACE(gate);
    InformationFilterOptions options;
    options.gate_chi2 = gate;
    double nees_sum = 0.0;
    for (int run = 0; run < kRuns; ++run) {
      std::mt19937 rng(100 + run);
      const Scene scene = MakeScene(4, 60, &rng);
      InformationFilter filter(options, scene.camera);
      testing::DenseReferenceFilter dense(options.anchor_information, scene.camera,
                                          options.min_sightings);
      const std::vector<FeatureObservation> first = Observe(scene, 0, true, &rng);
      filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
      dense.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
      for (size_t i = 1; i < scene.poses.size(); ++i) {
        std::vector<FeatureObservation> observations = Observe(scene, i, true, &rng);
        Vector6d initial = scene.poses[i];
        if (gate > 0.0) {
          std::vector<int64_t> ids;
          for (const FeatureObservation& o : observations) ids.push_back(o.feature_id);
          const GatedObservations gated = GateObservations(
              filter, initial, observations, filter.JointFeatureCovariance(ids), true);
          observations = gated.observations;
          if (gated.pose_fitted) initial = gated.T_w_c;
        }
        filter.AddPose(scene.frame_ids[i], initial, observations);
        dense.AddPose(scene.frame_ids[i], initial, observations);
      }
      const int last = scene.frame_ids.back();
      std::vector<int> indices;
      for (int k = 0; k < 6; ++k) indices.push_back(dense.PoseIndex(last) + k);
      const Matrix6d dense_covariance = dense.CovarianceOf(indices);
      const double nees =
          PoseNees(filter.pose(last), scene.poses.back(), filter.PoseCovariance(last));
      const double dense_nees = PoseNees(dense.pose(last), scene.poses.back(), dense_covariance);
      EXPECT_NEAR(nees, dense_nees, 1e-4 * (1.0 + dense_nees)) << "run " << run;
      nees_sum += nees;
    }
    const auto [lo, hi] = NeesBand(6, kRuns, 0.99);
    EXPECT_GT(nees_sum / kRuns, lo);
    EXPECT_LT(nees_sum / kRuns, hi);
  }
}

}  // namespace
}  // namespace ieslam
