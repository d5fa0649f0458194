#include "backend/depth_alignment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include <Eigen/Eigenvalues>

#include "core/error.h"
#include "core/kinect_range_imager.h"

namespace ieslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

// An axis-aligned box [lo, hi]: the ray's first entry (outside) or its exit (inside), by slabs.
double RayBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& lo,
              const Eigen::Vector3d& hi, bool from_inside) {
  double t_near = -1e300, t_far = 1e300;
  for (int k = 0; k < 3; ++k) {
    const double t1 = (lo[k] - o[k]) / d[k], t2 = (hi[k] - o[k]) / d[k];
    t_near = std::max(t_near, std::min(t1, t2));
    t_far = std::min(t_far, std::max(t1, t2));
  }
  if (t_near > t_far || t_far <= 0.0) return -1.0;
  return from_inside ? t_far : (t_near > 0.0 ? t_near : -1.0);
}

// The depth image of a room (2 x 2.5 x 3.5 m, y down, the floor at y = 1) with two boxes
// standing on the floor, from the range imager at T_w_r; z depth, with Gaussian noise of the
// imager's model when `rng` is given. The room is narrow enough for its side walls to be in
// view: they and the boxes' sides fix the position across it.
cv::Mat RenderRoom(const RangeImager& range, const Eigen::Isometry3d& T_w_r,
                   std::mt19937* rng = nullptr) {
  std::normal_distribution<double> normal(0.0, 1.0);
  cv::Mat depth(range.camera.height, range.camera.width, CV_32FC1, cv::Scalar(0.0f));
  const Eigen::Vector3d o = T_w_r.translation();
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      const Eigen::Vector3d ray_r = range.camera.Unproject(Eigen::Vector2d(x, y));  // z = 1
      const Eigen::Vector3d d = T_w_r.linear() * ray_r;
      double t = RayBox(o, d, {-1.0, -1.5, -1.0}, {1.0, 1.0, 2.5}, true);
      for (const auto& [lo, hi] :
           {std::pair<Eigen::Vector3d, Eigen::Vector3d>{{-0.7, 0.3, 1.0}, {-0.1, 1.0, 1.6}},
            std::pair<Eigen::Vector3d, Eigen::Vector3d>{{0.3, 0.5, 1.3}, {0.6, 1.0, 1.9}}}) {
        const double t_box = RayBox(o, d, lo, hi, false);
        if (t_box > 0.0 && t_box < t) t = t_box;
      }
      if (t <= 0.0) continue;
      double z = t;  // ray_r has z = 1
      if (rng != nullptr) z += range.noise.Sigma(t * ray_r.norm()) * normal(*rng);
      depth.at<float>(y, x) = static_cast<float>(z);
    }
  }
  return depth;
}

// A camera 1 m above the floor (y = 0), looking 20 deg down (so that the floor, seen face-on
// enough, fixes the height) plus pitch_deg, turned by yaw_deg about the vertical.
Eigen::Isometry3d Pose(double x, double y, double z, double yaw_deg, double pitch_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd((pitch_deg - 20.0) * kDeg, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() << x, y, z;
  return T;
}

Eigen::Isometry3d Perturb(const Eigen::Isometry3d& T, const Eigen::Vector3d& omega,
                          const Eigen::Vector3d& v) {
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  D.linear() = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
  D.translation() = v;
  return D * T;
}

double AngleDeg(const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) {
  return Eigen::AngleAxisd(A.linear().transpose() * B.linear()).angle() / kDeg;
}

RangeCloud Cloud(const RangeImager& range, const Eigen::Isometry3d& T_w_r,
                 std::mt19937* rng = nullptr) {
  return MakeRangeCloud(RenderRoom(range, T_w_r, rng), range, Eigen::Isometry3d::Identity(),
                        RangeCloudOptions(), "rendered");
}

TEST(DepthAlignmentTest, PairAlignmentRecoversTheRelativePose) {
  const RangeImager range = testing_core::KinectRangeImager();
  const Eigen::Isometry3d T_w_a = Pose(0.0, 0.0, 0.0, 0.0, 0.0);
  const Eigen::Isometry3d T_w_b = Pose(0.15, -0.05, 0.1, 8.0, -4.0);
  const RangeCloud a = Cloud(range, T_w_a), b = Cloud(range, T_w_b);
  const Eigen::Isometry3d truth = T_w_b.inverse() * T_w_a;
  // 1.5 cm and 1.5 deg off: what the front end's registration could leave.
  const Eigen::Isometry3d start =
      Perturb(truth, Eigen::Vector3d(1.0, -0.5, 0.8).normalized() * 1.5 * kDeg,
              Eigen::Vector3d(0.01, 0.01, -0.005));
  const PairAlignment aligned = AlignRangeClouds(a, b, start, DepthAlignmentOptions());
  ASSERT_TRUE(aligned.usable) << aligned.why_not;
  // Noise-free planes: interpolation between grid points on a plane is exact.
  EXPECT_LT((aligned.T_t_s.translation() - truth.translation()).norm(), 2e-4);
  EXPECT_LT(AngleDeg(aligned.T_t_s, truth), 0.01);
  EXPECT_GT(aligned.overlap, 0.5);
  // Walls, floor, ceiling and the box determine all six directions.
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(aligned.information);
  EXPECT_GT(eigen.eigenvalues().minCoeff(), 1e3) << eigen.eigenvalues().transpose();
}

TEST(DepthAlignmentTest, NoisyDepthStaysWithinTheInformationItReports) {
  const RangeImager range = testing_core::KinectRangeImager();
  std::mt19937 rng(5);
  const Eigen::Isometry3d T_w_a = Pose(0.0, 0.0, 0.0, 0.0, 0.0);
  const Eigen::Isometry3d T_w_b = Pose(-0.1, 0.05, 0.2, -10.0, 3.0);
  const RangeCloud a = Cloud(range, T_w_a, &rng), b = Cloud(range, T_w_b, &rng);
  const Eigen::Isometry3d truth = T_w_b.inverse() * T_w_a;
  const PairAlignment aligned = AlignRangeClouds(
      a, b, Perturb(truth, Eigen::Vector3d(0.0, 1.0 * kDeg, 0.0), Eigen::Vector3d(0.0, 0.0, 0.01)),
      DepthAlignmentOptions());
  ASSERT_TRUE(aligned.usable) << aligned.why_not;
  // Error in the chart T = [Exp(omega), v] T_t_s; its Mahalanobis norm under the reported
  // information is chi-square with 6 degrees of freedom if the noise is as modelled (the
  // interpolation of a noisy target adds a little): 99.9% below 22.5.
  const Eigen::Isometry3d E = truth * aligned.T_t_s.inverse();
  Vector6d error;
  error << Eigen::AngleAxisd(E.linear()).angle() * Eigen::AngleAxisd(E.linear()).axis(),
      E.translation();
  EXPECT_LT(error.dot(aligned.information * error), 22.5)
      << error.transpose() << " it " << aligned.iterations << " n " << aligned.correspondences
      << " rs " << aligned.robust_sigma;
  EXPECT_LT(E.translation().norm(), 0.01);
  EXPECT_GT(aligned.robust_sigma, 0.3);  // the whitened residuals have about unit spread
  EXPECT_LT(aligned.robust_sigma, 1.5);
}

TEST(DepthAlignmentTest, APlaneLeavesItsOwnDirectionsUndetermined) {
  RangeImager range = testing_core::KinectRangeImager();
  // Close to the far wall (z = 2.5), looking straight at it: only the wall is seen.
  const Eigen::Isometry3d T_w_a = Pose(0.0, -0.3, 1.7, 0.0, 20.0);
  const Eigen::Isometry3d T_w_b = Pose(0.05, -0.28, 1.75, 2.0, 20.0);
  const RangeCloud a = Cloud(range, T_w_a), b = Cloud(range, T_w_b);
  const PairAlignment aligned =
      AlignRangeClouds(a, b, T_w_b.inverse() * T_w_a, DepthAlignmentOptions());
  ASSERT_TRUE(aligned.usable) << aligned.why_not;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(aligned.information);
  const Vector6d lambda = eigen.eigenvalues();  // ascending
  // Sliding along the wall (2 translations) and turning about its normal: no information.
  EXPECT_LT(lambda[2], 1e-6 * lambda[5]) << lambda.transpose();
  EXPECT_GT(lambda[3], 1e-3 * lambda[5]) << lambda.transpose();
}

TEST(DepthAlignmentTest, CloudsThatShareNothingGiveNoConstraint) {
  const RangeImager range = testing_core::KinectRangeImager();
  std::map<int, RangeCloud> clouds;
  std::map<int, Eigen::Isometry3d> T_w_c;
  T_w_c[0] = Pose(0.0, 0.0, 0.0, 0.0, 0.0);
  T_w_c[1] = Pose(0.0, 0.0, 0.0, 180.0, 0.0);  // looking the other way
  for (const auto& [frame, T] : T_w_c) clouds[frame] = Cloud(range, T);
  DepthAlignmentStats stats;
  EXPECT_TRUE(AlignCloudPairs(clouds, T_w_c, DepthAlignmentOptions(), &stats).empty());
  EXPECT_EQ(stats.pairs_tried, 0);
}

// Four frames, the first the anchor, the others started up to 1.5 cm and 0.5 deg per axis
// off (the filter's keyframes on 7scenes-dev differ from the bundle adjustment's by 1 cm and
// 0.3 deg RMS); with no feature observations at all the clouds alone bring them back.
TEST(DepthAlignmentTest, RefinementWithCloudsAloneRecoversThePoses) {
  const RangeImager range = testing_core::KinectRangeImager();
  std::map<int, Eigen::Isometry3d> truth = {{0, Pose(0.0, 0.0, 0.0, 0.0, 0.0)},
                                            {3, Pose(0.2, 0.0, 0.1, 10.0, -3.0)},
                                            {7, Pose(0.4, -0.1, 0.3, 20.0, 2.0)},
                                            {9, Pose(-0.2, 0.1, 0.2, -12.0, 5.0)}};
  std::map<int, RangeCloud> clouds;
  BundleAdjustmentProblem problem;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const auto& [frame, T] : truth) {
    clouds[frame] = Cloud(range, T);
    problem.T_w_c[frame] =
        frame == 0 ? T
                   : Perturb(T, Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 0.5 * kDeg,
                             Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 0.015);
  }
  problem.anchor_frame_id = 0;
  DepthAlignmentOptions options;
  options.num_threads = 2;
  DepthAlignmentStats stats;
  const BundleAdjustmentResult result = SolveWithDepthAlignment(
      problem, range.camera, clouds, BundleAdjustmentOptions(), options, &stats);
  ASSERT_TRUE(result.usable) << result.termination;
  EXPECT_EQ(stats.constraints, 6);  // every pair overlaps
  EXPECT_GE(stats.rounds, 1);
  // The covariances of the round that stands (the earlier rounds' are not computed).
  EXPECT_EQ(result.pose_covariances.size(), truth.size()) << result.covariance_error;
  // From up to 2.6 cm and 0.9 deg off to within a millimetre and a tenth of a degree (the
  // pairs' alignments are exact to ~0.2 mm; creases at the box and the room's corners, which
  // the clouds blur over a grid cell, leave the rest).
  for (const auto& [frame, T] : truth) {
    EXPECT_LT((result.T_w_c.at(frame).translation() - T.translation()).norm(), 1e-3) << frame;
    EXPECT_LT(AngleDeg(result.T_w_c.at(frame), T), 0.1) << frame;
  }
  // The same constraints on one thread.
  options.num_threads = 1;
  const auto one = AlignCloudPairs(clouds, problem.T_w_c, options);
  options.num_threads = 3;
  const auto three = AlignCloudPairs(clouds, problem.T_w_c, options);
  ASSERT_EQ(one.size(), three.size());
  for (size_t k = 0; k < one.size(); ++k) {
    EXPECT_EQ(one[k].sqrt_information, three[k].sqrt_information);
    EXPECT_EQ(one[k].T_sj_si.matrix(), three[k].T_sj_si.matrix());
  }
}

// A later round's pairs start from their own earlier alignments (SolveWithDepthAlignment
// passes the ones its last solve kept): from there they take fewer steps and end where the
// alignment from the poses does, within its convergence step.
TEST(DepthAlignmentTest, PairsStartedFromTheirOwnAlignmentEndThereInFewerSteps) {
  const RangeImager range = testing_core::KinectRangeImager();
  std::map<int, Eigen::Isometry3d> truth = {{0, Pose(0.0, 0.0, 0.0, 0.0, 0.0)},
                                            {3, Pose(0.2, 0.0, 0.1, 10.0, -3.0)},
                                            {7, Pose(0.4, -0.1, 0.3, 20.0, 2.0)}};
  std::map<int, RangeCloud> clouds;
  std::map<int, Eigen::Isometry3d> started;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const auto& [frame, T] : truth) {
    clouds[frame] = Cloud(range, T, &rng);
    started[frame] = Perturb(T, Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 0.5 * kDeg,
                             Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 0.015);
  }
  DepthAlignmentOptions options;
  DepthAlignmentStats cold_stats, warm_stats;
  const std::vector<RelativePoseConstraint> cold =
      AlignCloudPairs(clouds, started, options, &cold_stats);
  ASSERT_EQ(cold.size(), 3u);
  const std::vector<RelativePoseConstraint> warm =
      AlignCloudPairs(clouds, started, options, &warm_stats, &cold);
  ASSERT_EQ(warm.size(), cold.size());
  EXPECT_LT(warm_stats.iterations, cold_stats.iterations / 2)
      << warm_stats.iterations << " against " << cold_stats.iterations;
  for (size_t k = 0; k < cold.size(); ++k) {
    EXPECT_EQ(warm[k].frame_i, cold[k].frame_i);
    EXPECT_EQ(warm[k].frame_j, cold[k].frame_j);
    const Eigen::Isometry3d D = cold[k].T_sj_si.inverse() * warm[k].T_sj_si;
    EXPECT_LT(D.translation().norm(), 2e-4) << k;
    EXPECT_LT(Eigen::AngleAxisd(D.linear()).angle(), 2e-4) << k;
  }
  // A start further than the coarse phase's gate from where the poses put the pair is not
  // taken: the alignment goes from the poses, as without starts.
  std::vector<RelativePoseConstraint> far = cold;
  for (RelativePoseConstraint& c : far) {
    c.T_sj_si.translation() += Eigen::Vector3d(0.0, 0.0, 2.0 * options.initial_gate_m);
  }
  DepthAlignmentStats far_stats;
  const std::vector<RelativePoseConstraint> from_poses =
      AlignCloudPairs(clouds, started, options, &far_stats, &far);
  ASSERT_EQ(from_poses.size(), cold.size());
  EXPECT_EQ(far_stats.iterations, cold_stats.iterations);
  for (size_t k = 0; k < cold.size(); ++k) {
    EXPECT_EQ(from_poses[k].T_sj_si.matrix(), cold[k].T_sj_si.matrix()) << k;
  }
}

// A stop request, wherever it comes (before a round, at a solve's start or during its
// iterations), leaves the alternation interrupted: a half-done refinement is no refinement.
// Every poll of the request is tried as the first that says stop.
TEST(DepthAlignmentTest, AStopAtAnyPollInterruptsTheAlternation) {
  const RangeImager range = testing_core::KinectRangeImager();
  const std::map<int, Eigen::Isometry3d> truth = {{0, Pose(0.0, 0.0, 0.0, 0.0, 0.0)},
                                                  {3, Pose(0.2, 0.0, 0.1, 10.0, -3.0)}};
  std::map<int, RangeCloud> clouds;
  BundleAdjustmentProblem problem;
  for (const auto& [frame, T] : truth) {
    clouds[frame] = Cloud(range, T);
    problem.T_w_c[frame] = frame == 0 ? T
                                      : Perturb(T, Eigen::Vector3d(0.0, 0.01, 0.0),
                                                Eigen::Vector3d(0.01, -0.005, 0.0));
  }
  problem.anchor_frame_id = 0;
  DepthAlignmentOptions options;
  options.rounds = 2;
  options.convergence_m = 0.0;  // both rounds
  int polls = 0;
  BundleAdjustmentOptions ba;
  ba.stop = [&polls] {
    ++polls;
    return false;
  };
  const BundleAdjustmentResult complete =
      SolveWithDepthAlignment(problem, range.camera, clouds, ba, options);
  ASSERT_TRUE(complete.usable && !complete.interrupted) << complete.termination;
  const int all_polls = polls;
  ASSERT_GT(all_polls, 4);
  for (int first_stop = 1; first_stop <= all_polls; ++first_stop) {
    polls = 0;
    ba.stop = [&polls, first_stop] { return ++polls >= first_stop; };
    const BundleAdjustmentResult stopped =
        SolveWithDepthAlignment(problem, range.camera, clouds, ba, options);
    EXPECT_TRUE(stopped.interrupted) << "stopped at poll " << first_stop << " of " << all_polls;
  }
}

// Each frame keeps the most overlapping partner of each run of its partners, but a run
// holding a pair with its own converged alignment keeps that pair instead: the choice then
// stays put from round to round where the poses move by millimetres. Three frames along a
// turn, one partner each: the neighbours overlap most, so the outer pair is chosen only as
// a pair with a start.
TEST(DepthAlignmentTest, APairWithItsOwnAlignmentIsKeptOverAMoreOverlappingOne) {
  const RangeImager range = testing_core::KinectRangeImager();
  const std::map<int, Eigen::Isometry3d> T_w_c = {{0, Pose(0.0, 0.0, 0.0, 0.0, 0.0)},
                                                  {1, Pose(0.05, 0.0, 0.0, 6.0, 0.0)},
                                                  {2, Pose(0.1, 0.0, 0.0, 12.0, 0.0)}};
  std::map<int, RangeCloud> clouds;
  for (const auto& [frame, T] : T_w_c) clouds[frame] = Cloud(range, T);
  DepthAlignmentOptions options;
  options.max_partners = 1;
  const auto has_pair = [](const std::vector<RelativePoseConstraint>& constraints, int i, int j) {
    return std::any_of(
        constraints.begin(), constraints.end(),
        [&](const RelativePoseConstraint& c) { return c.frame_i == i && c.frame_j == j; });
  };
  const std::vector<RelativePoseConstraint> chosen = AlignCloudPairs(clouds, T_w_c, options);
  ASSERT_FALSE(chosen.empty());
  EXPECT_FALSE(has_pair(chosen, 0, 2));
  RelativePoseConstraint outer;
  outer.frame_i = 0;
  outer.frame_j = 2;
  outer.T_sj_si = T_w_c.at(2).inverse() * T_w_c.at(0);  // the range imager is the camera
  std::vector<RelativePoseConstraint> starts = {outer};
  DepthAlignmentStats stats;
  const std::vector<RelativePoseConstraint> kept =
      AlignCloudPairs(clouds, T_w_c, options, &stats, &starts);
  EXPECT_TRUE(has_pair(kept, 0, 2));
  // Frames 0 and 2 both keep the outer pair; frame 1 keeps one of its neighbours.
  EXPECT_EQ(stats.pairs_tried, 2);
  // A start beyond the gate is no start: the choice is the one without.
  starts.front().T_sj_si.translation().z() += 2.0 * options.initial_gate_m;
  EXPECT_FALSE(has_pair(AlignCloudPairs(clouds, T_w_c, options, nullptr, &starts), 0, 2));
}

// Eight views around the room, their depth with noise and, when `correlated`, each scaled by
// +-2% (a range error shared by a frame's points), and the problem started from poses a
// centimetre and a few tenths of a degree off; `truth` gets the true poses.
void EightViews(const RangeImager& range, bool correlated, std::map<int, Eigen::Isometry3d>* truth,
                std::map<int, RangeCloud>* clouds, BundleAdjustmentProblem* problem) {
  std::mt19937 rng(5);
  for (int frame = 0; frame < 8; ++frame) {
    const double a = frame / 8.0 * 2.0 * M_PI;
    const Eigen::Isometry3d T = Pose(0.15 * std::cos(a), 0.05 * std::sin(2 * a), 0.15 * std::sin(a),
                                     12.0 * std::sin(a), 4.0 * std::cos(a));
    (*truth)[frame] = T;
    cv::Mat depth = RenderRoom(range, T, &rng);
    if (correlated) depth *= 1.0 + (frame % 2 == 0 ? 1.0 : -1.0) * 0.02;
    (*clouds)[frame] = MakeRangeCloud(depth, range, Eigen::Isometry3d::Identity(),
                                      RangeCloudOptions(), "rendered");
    problem->T_w_c[frame] = frame == 0 ? T
                                       : Perturb(T, Eigen::Vector3d(0.3, -0.2, 0.1) * kDeg,
                                                 Eigen::Vector3d(0.01, -0.005, 0.008));
  }
  problem->anchor_frame_id = 0;
}

// The clouds' sampling follows what their constraints show. Where the range errors are as
// the noise model states (independent per pixel), the constraints are as precise as they
// state and the later rounds sample twice as densely. Where each frame's depth is off by its
// own scale (+-2%, within a Kinect's depth calibration error; correlated across the whole
// image), the constraints disagree far beyond their stated precision (a variance factor of
// about 25) and the sampling stays as it started.
TEST(DepthAlignmentTest, CloudsAreSampledDenselyOnlyWhereTheirErrorsAreIndependent) {
  const RangeImager range = testing_core::KinectRangeImager();
  for (const bool correlated : {false, true}) {
    SCOPED_TRACE(correlated ? "depth scale errors" : "independent noise");
    std::map<int, Eigen::Isometry3d> truth;
    std::map<int, RangeCloud> clouds;
    BundleAdjustmentProblem problem;
    EightViews(range, correlated, &truth, &clouds, &problem);
    DepthAlignmentOptions options;
    options.num_threads = 2;
    // Every round counts as converged: the rounds that remain are the ones that sample
    // more densely.
    options.convergence_m = 1.0;
    ASSERT_EQ(options.sample_step, 2 * options.dense_sample_step);
    DepthAlignmentStats stats;
    const BundleAdjustmentResult result = SolveWithDepthAlignment(
        problem, range.camera, clouds, BundleAdjustmentOptions(), options, &stats);
    ASSERT_TRUE(result.usable) << result.termination;
    EXPECT_GE(stats.constraints, 20);
    // Whether the rounds end by convergence (correlated) or at the last one, the result that
    // stands has its covariances.
    EXPECT_EQ(result.pose_covariances.size(), truth.size()) << result.covariance_error;
    if (correlated) {
      EXPECT_GT(stats.variance_factor, 10.0);
      EXPECT_EQ(stats.sample_step, options.sample_step);
      EXPECT_EQ(stats.rounds, 1);
    } else {
      EXPECT_LT(stats.variance_factor, 2.0);
      EXPECT_EQ(stats.sample_step, options.dense_sample_step);
      EXPECT_EQ(stats.rounds, 2);
    }
  }
}

// A round before the last solves with fewer rounds of rejections and weighing; when it ends
// the alternation after all, it is solved again with every round, so the result is the one
// the alternation would give without the shortcut.
TEST(DepthAlignmentTest, ARoundThatEndsTheAlternationEarlyIsSolvedWithEveryRejectionRound) {
  const RangeImager range = testing_core::KinectRangeImager();
  std::map<int, Eigen::Isometry3d> truth;
  std::map<int, RangeCloud> clouds;
  BundleAdjustmentProblem problem;
  EightViews(range, /*correlated=*/true, &truth, &clouds, &problem);
  DepthAlignmentOptions options;
  options.convergence_m = 1.0;  // the first round ends the alternation
  ASSERT_GT(options.rounds, 1);
  std::map<int, BundleAdjustmentResult> results;
  std::map<int, DepthAlignmentStats> stats;
  for (const int early : {-1, 1}) {
    options.early_rejection_rounds = early;
    results[early] = SolveWithDepthAlignment(problem, range.camera, clouds,
                                             BundleAdjustmentOptions(), options, &stats[early]);
    ASSERT_TRUE(results[early].usable) << results[early].termination;
    EXPECT_EQ(stats[early].rounds, 1);
  }
  EXPECT_GT(stats[1].variance_factor, 10.0);
  EXPECT_EQ(stats[1].variance_factor, stats[-1].variance_factor);
  for (const auto& [frame, T] : results[-1].T_w_c) {
    EXPECT_EQ(results[1].T_w_c.at(frame).matrix(), T.matrix()) << frame;
  }
  EXPECT_EQ(results[1].pose_covariances.size(), truth.size()) << results[1].covariance_error;
}

// The clouds are in the range imager's frame, the poses the colour camera's: with the
// imager 2.5 cm and 3 deg off the camera the refinement still places the camera poses.
TEST(DepthAlignmentTest, RangeImagerOffTheColourCameraIsAccountedFor) {
  const RangeImager range = testing_core::KinectRangeImager();
  Eigen::Isometry3d T_c_r = Eigen::Isometry3d::Identity();
  T_c_r.linear() =
      Eigen::AngleAxisd(3.0 * kDeg, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  T_c_r.translation() << 0.025, -0.004, 0.002;
  const std::map<int, Eigen::Isometry3d> truth = {{0, Pose(0.0, 0.0, 0.0, 0.0, 0.0)},
                                                  {1, Pose(0.15, -0.05, 0.1, 8.0, -4.0)},
                                                  {2, Pose(-0.1, 0.05, 0.2, -10.0, 3.0)}};
  std::map<int, RangeCloud> clouds;
  BundleAdjustmentProblem problem;
  for (const auto& [frame, T] : truth) {
    clouds[frame] =
        MakeRangeCloud(RenderRoom(range, T * T_c_r), range, T_c_r, RangeCloudOptions(), "rendered");
    problem.T_w_c[frame] = frame == 0 ? T
                                      : Perturb(T, Eigen::Vector3d(0.3, -0.2, 0.4) * kDeg,
                                                Eigen::Vector3d(0.01, -0.008, 0.005));
  }
  problem.anchor_frame_id = 0;
  const BundleAdjustmentResult result = SolveWithDepthAlignment(
      problem, range.camera, clouds, BundleAdjustmentOptions(), DepthAlignmentOptions());
  ASSERT_TRUE(result.usable) << result.termination;
  // Within 2 mm and 0.05 deg (from 1.4 cm and 0.5 deg): the alignments of frames 0-1 and 0-2
  // are exact to 0.1 mm, while 1-2, which sees little across the room, settles 3 mm from
  // the truth even when started there.
  for (const auto& [frame, T] : truth) {
    EXPECT_LT((result.T_w_c.at(frame).translation() - T.translation()).norm(), 2e-3) << frame;
    EXPECT_LT(AngleDeg(result.T_w_c.at(frame), T), 0.05) << frame;
  }
}

TEST(DepthAlignmentTest, BadOptionsAreNamed) {
  DepthAlignmentOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why));
  options.final_gate_m = 0.1;  // above the initial gate
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("gate"), std::string::npos) << why;
  options = DepthAlignmentOptions();
  options.min_overlap = 0.0;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("min_overlap"), std::string::npos) << why;
  options = DepthAlignmentOptions();
  options.rounds = -1;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_THROW(AlignCloudPairs({}, {}, options), ConfigError);
}

}  // namespace
}  // namespace ieslam
