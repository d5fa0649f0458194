#include "backend/evaluation/evaluation.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "backend/evaluation/evaluation_io.h"
#include "core/error.h"
#include "core/trajectory.h"

namespace ieslam {
namespace {

const std::string kTumEvalDir = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-eval/";

// The way evaluate_ate.py / evaluate_rpe.py print a number ("%f").
std::string Printed(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%f", value);
  return buffer;
}

// The reference numbers of tum-eval/README.md, printed by TUM's own scripts for a real
// ORB-SLAM estimate of fr2_desk. Matching them digit for digit is what makes this evaluator's
// numbers comparable with published ones.
class TumReferenceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // The ground truth repeats one stamp (1311868229.5760), which ReadTumTrajectory rejects.
    gt_ = new Trajectory(ReadTumTrajectoryForEvaluation(kTumEvalDir + "fr2_desk_groundtruth.txt"));
    est_ = new Trajectory(ReadTumTrajectoryForEvaluation(kTumEvalDir + "fr2_desk_ORB.txt"));
  }
  static void TearDownTestSuite() {
    delete gt_;
    delete est_;
  }
  static const Trajectory* gt_;
  static const Trajectory* est_;
};
const Trajectory* TumReferenceTest::gt_ = nullptr;
const Trajectory* TumReferenceTest::est_ = nullptr;

TEST_F(TumReferenceTest, AteMatchesEvaluateAte) {
  const AteResult ate = ComputeAte(*gt_, *est_, EvaluationOptions());
  EXPECT_EQ(ate.translation.count, 2223u);
  EXPECT_EQ(ate.pairs.size(), 2223u);
  EXPECT_EQ(Printed(ate.translation.rmse), "0.008144");
  EXPECT_EQ(Printed(ate.translation.mean), "0.007514");
  EXPECT_EQ(Printed(ate.translation.median), "0.007432");
  EXPECT_EQ(Printed(ate.translation.min), "0.000332");
  EXPECT_EQ(Printed(ate.translation.max), "0.024329");
  // The alignment is a rotation, not a reflection.
  EXPECT_NEAR(ate.T_gt_est.linear().determinant(), 1.0, 1e-12);
}

TEST_F(TumReferenceTest, RpeOneSecondMatchesEvaluateRpe) {
  const RpeResult rpe = ComputeRpe(*gt_, *est_, EvaluationOptions());
  EXPECT_EQ(rpe.translation.count, 1998u);
  EXPECT_EQ(rpe.rotation.count, 1998u);
  EXPECT_EQ(Printed(rpe.translation.rmse), "0.007161");
  EXPECT_EQ(Printed(rpe.rotation.rmse), "0.455005");
}

TEST_F(TumReferenceTest, RpeOneFrameMatchesEvaluateRpe) {
  EvaluationOptions options;
  options.delta_unit = DeltaUnit::kFrames;
  const RpeResult rpe = ComputeRpe(*gt_, *est_, options);
  EXPECT_EQ(rpe.translation.count, 2060u);
  EXPECT_EQ(Printed(rpe.translation.rmse), "0.003381");
  for (const RpePair& pair : rpe.pairs) {
    ASSERT_LT(pair.est_timestamp_0, pair.est_timestamp_1);
    ASSERT_LT(pair.est_timestamp_1 - pair.est_timestamp_0, 0.1);  // one ORB frame (~30 Hz)
  }
}

// A 10 Hz trajectory that turns and climbs, so that the alignment is well posed.
Trajectory MakeTrajectory(int n) {
  Trajectory trajectory;
  for (int k = 0; k < n; ++k) {
    const double t = 0.1 * k;
    TimedPose pose;
    pose.timestamp = 1000.0 + t;
    pose.T_w_c.linear() = (Eigen::AngleAxisd(0.3 * t, Eigen::Vector3d::UnitZ()) *
                           Eigen::AngleAxisd(0.1 * std::sin(t), Eigen::Vector3d::UnitX()))
                              .toRotationMatrix();
    pose.T_w_c.translation() = Eigen::Vector3d(2.0 * std::cos(0.4 * t), std::sin(0.4 * t), 0.2 * t);
    trajectory.push_back(pose);
  }
  return trajectory;
}

TEST(EvaluationTest, RigidlyMovedAndShrunkGroundTruthHasNoError) {
  const Trajectory gt = MakeTrajectory(60);
  Eigen::Isometry3d T_other_w = Eigen::Isometry3d::Identity();
  T_other_w.linear() =
      Eigen::AngleAxisd(1.2, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T_other_w.translation() = Eigen::Vector3d(5.0, -3.0, 0.7);
  Trajectory est = gt;
  for (TimedPose& pose : est) {
    pose.T_w_c = T_other_w * pose.T_w_c;
    pose.T_w_c.translation() *= 0.5;  // undone by options.scale
  }
  EvaluationOptions options;
  options.scale = 2.0;
  const EvaluationResult result = EvaluateTrajectories(gt, est, options);
  EXPECT_EQ(result.ate.translation.count, 60u);
  EXPECT_LT(result.ate.translation.max, 1e-12);
  EXPECT_TRUE(result.ate.T_gt_est.isApprox(T_other_w.inverse(), 1e-12));
  EXPECT_LT(result.rpe.translation.max, 1e-12);
  EXPECT_LT(result.rpe.rotation.max, 1e-5);  // degrees; arccos near 1 is coarse, as in TUM
  ASSERT_EQ(result.aligned_estimate.size(), gt.size());
  for (std::size_t k = 0; k < gt.size(); ++k) {
    EXPECT_TRUE(result.aligned_estimate[k].T_w_c.isApprox(gt[k].T_w_c, 1e-12)) << k;
  }
  // Without the scale the same estimate is wrong by metres.
  EXPECT_GT(ComputeAte(gt, est, EvaluationOptions()).translation.rmse, 0.1);
}

TEST(EvaluationTest, ConstantDriftGivesItsRelativeError) {
  const int n = 51;
  Trajectory gt = MakeTrajectory(n);
  Trajectory est = gt;
  // Each frame the estimate drifts 1 cm along the world x axis more than the ground truth.
  for (int k = 0; k < n; ++k) est[k].T_w_c.translation().x() += 0.01 * k;
  EvaluationOptions options;  // delta 1 s = 10 frames at 10 Hz
  const RpeResult seconds = ComputeRpe(gt, est, options);
  // j = i + 10 must stay before the last estimate: i = 0 .. n - 12.
  EXPECT_EQ(seconds.translation.count, static_cast<std::size_t>(n - 11));
  EXPECT_NEAR(seconds.translation.min, 0.10, 1e-12);
  EXPECT_NEAR(seconds.translation.max, 0.10, 1e-12);
  EXPECT_NEAR(seconds.translation.std, 0.0, 1e-12);
  EXPECT_LT(seconds.rotation.max, 1e-5);

  options.delta = 2.0;
  options.delta_unit = DeltaUnit::kFrames;
  const RpeResult frames = ComputeRpe(gt, est, options);
  EXPECT_EQ(frames.translation.count, static_cast<std::size_t>(n - 3));
  EXPECT_NEAR(frames.translation.rmse, 0.02, 1e-12);

  // A world-yaw drift of 0.5 deg per frame: 5 deg of rotation error per second.
  Trajectory yawing = gt;
  for (int k = 0; k < n; ++k) {
    const double yaw = 0.5 * k * EIGEN_PI / 180.0;
    yawing[k].T_w_c.linear() =
        Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * gt[k].T_w_c.linear();
  }
  const RpeResult yaw = ComputeRpe(gt, yawing, EvaluationOptions());
  EXPECT_NEAR(yaw.rotation.min, 5.0, 1e-9);
  EXPECT_NEAR(yaw.rotation.max, 5.0, 1e-9);
}

TEST(EvaluationTest, RpeSkipsPairsInGroundTruthGaps) {
  Trajectory gt = MakeTrajectory(60);
  // Estimates half a period after the ground truth, so that no distance sits on the limit.
  Trajectory est = gt;
  for (TimedPose& pose : est) pose.timestamp += 0.05;
  gt.erase(gt.begin() + 30, gt.begin() + 35);  // no ground truth in 1003.0 .. 1003.4
  const RpeResult rpe = ComputeRpe(gt, est, EvaluationOptions());
  // Without the hole there are 60 - 11 pairs (i, i + 10). Estimates 31 and 32 (1003.15,
  // 1003.25) are more than two periods from any gt stamp, which removes pairs i = 21, 22,
  // 31, 32.
  EXPECT_EQ(rpe.translation.count, 49u - 4u);
  for (const RpePair& pair : rpe.pairs) {
    EXPECT_LT(std::abs(pair.gt_timestamp_0 - pair.est_timestamp_0), 0.2);
    EXPECT_LT(std::abs(pair.gt_timestamp_1 - pair.est_timestamp_1), 0.2);
  }
}

TEST(EvaluationTest, FewerThanThreePairsThrowsNamingTheFiles) {
  const Trajectory gt = MakeTrajectory(20);
  Trajectory est(gt.begin(), gt.begin() + 2);
  try {
    ComputeAte(gt, est, EvaluationOptions(), "gt.txt", "orb_estimate.txt");
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("orb_estimate.txt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("gt.txt"), std::string::npos) << e.what();
  }
  // Three poses, but a 5 s offset moves them away from the ground truth.
  est.assign(gt.begin(), gt.begin() + 3);
  EvaluationOptions options;
  options.offset_s = 5.0;
  EXPECT_THROW(ComputeAte(gt, est, options), DataError);
  // Three pairs align; RPE with a 1 s delta then has no pair in 0.2 s of estimate.
  EXPECT_EQ(ComputeAte(gt, est, EvaluationOptions()).translation.count, 3u);
  EXPECT_THROW(ComputeRpe(gt, est, EvaluationOptions()), DataError);
}

// A trajectory shorter than the RPE's delta still has its ATE; only when neither can be
// computed does the evaluation fail.
TEST(EvaluationTest, EvaluatesWhatCanBeComputedAndSaysWhyTheRestCannot) {
  const Trajectory gt = MakeTrajectory(20);
  const Trajectory est(gt.begin(), gt.begin() + 3);
  const EvaluationResult result = EvaluateTrajectories(gt, est, EvaluationOptions());
  EXPECT_TRUE(result.ate_unavailable.empty()) << result.ate_unavailable;
  EXPECT_EQ(result.ate.translation.count, 3u);
  EXPECT_EQ(result.aligned_estimate.size(), 3u);
  EXPECT_NE(result.rpe_unavailable.find("relative-pose pairs (delta 1 s)"), std::string::npos)
      << result.rpe_unavailable;

  // Two poses: no ATE (3 needed) and no RPE either.
  const Trajectory two(gt.begin(), gt.begin() + 2);
  try {
    EvaluateTrajectories(gt, two, EvaluationOptions(), "gt.txt", "two.txt");
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("no ATE: only 2 poses of two.txt"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("; no RPE: "), std::string::npos) << e.what();
  }
  EvaluationOptions bad;
  bad.max_diff_s = 0.0;
  EXPECT_THROW(EvaluateTrajectories(gt, est, bad), ConfigError);
}

TEST(EvaluationTest, FindClosestIndexKeepsTheReferenceTieBreak) {
  const std::vector<double> list = {0.0, 1.0, 2.0, 3.0};
  EXPECT_EQ(FindClosestIndex(list, -5.0), 0u);
  EXPECT_EQ(FindClosestIndex(list, 9.0), 3u);
  EXPECT_EQ(FindClosestIndex(list, 1.2), 1u);
  EXPECT_EQ(FindClosestIndex(list, 2.0), 2u);
  // 1.5 is as close to 1 as to 2; the bisection visits 2 first and keeps it.
  EXPECT_EQ(FindClosestIndex(list, 1.5), 2u);
}

TEST(EvaluationTest, OptionsAreChecked) {
  EvaluationOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why)) << why;
  options.max_diff_s = 0.0;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("max_diff_s"), std::string::npos) << why;
  const Trajectory gt = MakeTrajectory(20);
  EXPECT_THROW(ComputeAte(gt, gt, options), ConfigError);
  options = EvaluationOptions();
  options.delta = -1.0;
  EXPECT_FALSE(options.Check(&why));
  options = EvaluationOptions();
  options.scale = 0.0;
  EXPECT_FALSE(options.Check(&why));

  DeltaUnit unit = DeltaUnit::kSeconds;
  EXPECT_TRUE(ParseDeltaUnit("f", &unit));
  EXPECT_EQ(unit, DeltaUnit::kFrames);
  EXPECT_TRUE(ParseDeltaUnit("seconds", &unit));
  EXPECT_EQ(unit, DeltaUnit::kSeconds);
  EXPECT_FALSE(ParseDeltaUnit("m", &unit));
  EXPECT_EQ(DeltaUnitName(DeltaUnit::kFrames), "f");
}

}  // namespace
}  // namespace ieslam
