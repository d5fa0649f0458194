#include "frontend/simulation/simulation_trajectory.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/pose.h"
#include "frontend/simulation/paper_simulation.h"

namespace ieslam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

TEST(SimulationTrajectory, TrajectoryIsTwoLoopsOfEquallySpacedPoses) {
  const SimulationOptions o;
  const PaperTrajectory t = BuildPaperTrajectory(o.trajectory);
  ASSERT_EQ(t.T_w_c.size(), 300u);
  EXPECT_NEAR(t.spacing_m * 300, t.length_m, 1e-9);
  EXPECT_GT(t.length_m, 40.0);  // two loops of a 5 m-radius octagon
  std::vector<double> steps;
  for (int k = 1; k < 300; ++k) {
    steps.push_back((t.T_w_c[k].head<3>() - t.T_w_c[k - 1].head<3>()).norm());
  }
  // Equal arc length; a chord that cuts a corner is a little shorter.
  for (double s : steps) {
    EXPECT_LE(s, t.spacing_m + 1e-9);
    EXPECT_GE(s, 0.85 * t.spacing_m);
  }
  std::sort(steps.begin(), steps.end());
  EXPECT_NEAR(steps[steps.size() / 2], t.spacing_m, 1e-9);
  // The second loop passes close to the first (loop closure), but not through the same points.
  double max_extent = 0.0;
  for (int k = 0; k < 150; ++k) {
    const double gap = (t.T_w_c[k + 150].head<3>() - t.T_w_c[k].head<3>()).norm();
    EXPECT_LT(gap, 1.0) << "pose " << k;
    EXPECT_GT(gap, 0.1) << "pose " << k;
    max_extent = std::max(max_extent, (t.T_w_c[k].head<3>() - t.T_w_c[0].head<3>()).norm());
  }
  EXPECT_GT(max_extent, 8.0);
  // 3-D: the height varies along the path.
  double z_min = 1e9, z_max = -1e9;
  for (const Vector6d& T : t.T_w_c) {
    z_min = std::min(z_min, T.z());
    z_max = std::max(z_max, T.z());
  }
  EXPECT_GT(z_max - z_min, 1.0);
}

TEST(SimulationTrajectory, CameraRotatesContinuallyInAllThreeAngles) {
  const PaperTrajectory t = BuildPaperTrajectory(PaperTrajectoryOptions());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  double alpha_unwrapped = t.T_w_c[0](3);
  double alpha_lo = alpha_unwrapped, alpha_hi = alpha_unwrapped;
  for (size_t k = 0; k < t.T_w_c.size(); ++k) {
    const Eigen::Vector3d angles = t.T_w_c[k].tail<3>();
    lo = lo.cwiseMin(angles);
    hi = hi.cwiseMax(angles);
    EXPECT_LT(std::abs(angles(1)), 60.0 * kDeg);  // beta far from gimbal lock
    if (k > 0) {
      const Eigen::Vector3d previous = t.T_w_c[k - 1].tail<3>();
      alpha_unwrapped += WrapAngle(angles(0) - previous(0));
      alpha_lo = std::min(alpha_lo, alpha_unwrapped);
      alpha_hi = std::max(alpha_hi, alpha_unwrapped);
      // Never still: every step rotates the camera.
      EXPECT_GT(RotationAngleBetween(EulerZyxToRotation(previous), EulerZyxToRotation(angles)),
                0.2 * kDeg)
          << "pose " << k;
    }
  }
  EXPECT_GT(alpha_hi - alpha_lo, 2.0 * kPi);  // heading goes round with the loops
  EXPECT_GT(hi(1) - lo(1), 10.0 * kDeg);      // beta
  EXPECT_GT(hi(2) - lo(2), 10.0 * kDeg);      // gamma
  // Tilt of the optical axis out of the horizontal, and roll about it, both vary.
  double tilt_lo = 1e9, tilt_hi = -1e9;
  for (const Vector6d& T : t.T_w_c) {
    const double tilt = std::asin(EulerZyxToRotation(T.tail<3>())(2, 2));
    tilt_lo = std::min(tilt_lo, tilt);
    tilt_hi = std::max(tilt_hi, tilt);
  }
  EXPECT_GT(tilt_hi - tilt_lo, 10.0 * kDeg);
}

TEST(SimulationTrajectory, RectangleHasSharpTurnsAndPolygonDoesNot) {
  PaperTrajectoryOptions o;
  o.kind = SimulatedTrajectoryKind::kRectangle;
  const PaperTrajectory rectangle = BuildPaperTrajectory(o);
  ASSERT_EQ(rectangle.corner_poses.size(), 8u);  // 4 corners per loop, 2 loops
  std::vector<bool> after_corner(rectangle.T_w_c.size(), false);
  for (int k : rectangle.corner_poses) {
    ASSERT_GT(k, 0);
    after_corner[k] = true;
    const double step = std::abs(
        WrapAngle(CameraHeading(rectangle.T_w_c[k]) - CameraHeading(rectangle.T_w_c[k - 1])));
    EXPECT_GT(step, 60.0 * kDeg) << "corner at pose " << k;
  }
  for (size_t k = 1; k < rectangle.T_w_c.size(); ++k) {
    if (after_corner[k]) continue;
    const double step = std::abs(
        WrapAngle(CameraHeading(rectangle.T_w_c[k]) - CameraHeading(rectangle.T_w_c[k - 1])));
    EXPECT_LT(step, 10.0 * kDeg) << "pose " << k;
  }
  const PaperTrajectory polygon = BuildPaperTrajectory(PaperTrajectoryOptions());
  for (size_t k = 1; k < polygon.T_w_c.size(); ++k) {
    const double step =
        std::abs(WrapAngle(CameraHeading(polygon.T_w_c[k]) - CameraHeading(polygon.T_w_c[k - 1])));
    EXPECT_LT(step, 10.0 * kDeg) << "pose " << k;
  }
}

TEST(SimulationTrajectory, BadOptionsThrowConfigError) {
  PaperTrajectoryOptions bad;
  bad.polygon_sides = 2;
  EXPECT_THROW(BuildPaperTrajectory(bad), ConfigError);
  bad = PaperTrajectoryOptions();
  bad.num_poses = 1;
  EXPECT_THROW(BuildPaperTrajectory(bad), ConfigError);
}

}  // namespace
}  // namespace ieslam
