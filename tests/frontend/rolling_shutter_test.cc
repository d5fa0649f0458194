#include "frontend/rolling_shutter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {
namespace {

CameraVelocity TurningAndMoving() {
  CameraVelocity v;
  v.angular_rad_s = Eigen::Vector3d(0.9, -1.6, 0.4);  // ~105 deg/s, a fast hand-held turn
  v.linear_m_s = Eigen::Vector3d(0.3, -0.1, 0.2);
  return v;
}

TEST(RollingShutterTest, VelocityBetweenInvertsMotionOver) {
  const CameraVelocity v = TurningAndMoving();
  const CameraVelocity back = VelocityBetween(MotionOver(v, 1.0 / 30.0), 1.0 / 30.0);
  EXPECT_LT((back.angular_rad_s - v.angular_rad_s).norm(), 1e-12);
  EXPECT_LT((back.linear_m_s - v.linear_m_s).norm(), 1e-12);
  EXPECT_TRUE(MotionOver(v, 0.0).isApprox(Eigen::Isometry3d::Identity(), 1e-15));
}

TEST(RollingShutterTest, VelocityOfFrameIsTheCentralDifferenceOrOneSide) {
  CameraVelocity a, b;
  a.angular_rad_s = Eigen::Vector3d(1.0, 0.0, 0.0);
  b.angular_rad_s = Eigen::Vector3d(0.0, 2.0, 0.0);
  a.linear_m_s = Eigen::Vector3d(0.1, 0.0, 0.0);
  const double dt = 1.0 / 30.0;
  const auto both = VelocityOfFrame(MotionOver(a, dt), dt, MotionOver(b, 2 * dt), 2 * dt);
  ASSERT_TRUE(both);
  EXPECT_LT((both->angular_rad_s - Eigen::Vector3d(0.5, 1.0, 0.0)).norm(), 1e-12);
  EXPECT_LT((both->linear_m_s - Eigen::Vector3d(0.05, 0.0, 0.0)).norm(), 1e-12);
  const auto before = VelocityOfFrame(MotionOver(a, dt), dt, std::nullopt, 0.0);
  ASSERT_TRUE(before);
  EXPECT_LT((before->angular_rad_s - a.angular_rad_s).norm(), 1e-12);
  const auto after = VelocityOfFrame(std::nullopt, 0.0, MotionOver(b, dt), dt);
  ASSERT_TRUE(after);
  EXPECT_LT((after->angular_rad_s - b.angular_rad_s).norm(), 1e-12);
  EXPECT_FALSE(VelocityOfFrame(std::nullopt, 0.0, std::nullopt, 0.0));
}

// A camera moving at a constant velocity sees each world point from the pose of the row it
// lands on. Compensation must give back the point and the (u, v, d) the camera would have
// measured at the frame's timestamp, to rounding.
TEST(RollingShutterTest, CompensationRestoresTheViewOfTheFramesTimestamp) {
  Rig rig = SyntheticRig(SyntheticSensor::kRgbd);
  rig.colour_readout_s = 0.03;
  const CameraVelocity v = TurningAndMoving();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> lateral(-1.0, 1.0), depth(0.6, 4.0);
  int checked = 0;
  for (int i = 0; i < 200; ++i) {
    const double z = depth(rng);
    const Eigen::Vector3d p_mid(lateral(rng) * 0.5 * z, lateral(rng) * 0.35 * z, z);
    // The row the point is seen on, where the camera is at that row's time: a fixed point.
    double row = rig.colour.Project(p_mid).y();
    Eigen::Vector3d p_row = p_mid;
    for (int k = 0; k < 50; ++k) {
      p_row = MotionOver(v, rig.RowTimeOffset(row)).inverse() * p_mid;
      row = rig.colour.Project(p_row).y();
    }
    if (!rig.colour.InImage(rig.colour.Project(p_row))) continue;
    const LiftedPoint measured = LiftedPointAt(p_row, rig);
    const LiftedPoint compensated = CompensateRollingShutter(measured, row, v, rig);
    const LiftedPoint expected = LiftedPointAt(p_mid, rig);
    ASSERT_TRUE(compensated.valid);
    EXPECT_LT((compensated.p_c - p_mid).norm(), 1e-12 * z);
    EXPECT_LT((compensated.z - expected.z).norm(), 1e-9);
    EXPECT_LT((compensated.Q - expected.Q).norm(), 1e-15);
    ++checked;
  }
  EXPECT_GT(checked, 150);
}

TEST(RollingShutterTest, AGlobalShutterOrAStillCameraChangesNothing) {
  Rig rig = SyntheticRig(SyntheticSensor::kRgbd);
  const LiftedPoint point = LiftedPointAt(Eigen::Vector3d(0.3, -0.2, 1.7), rig);
  const LiftedPoint global = CompensateRollingShutter(point, 10.0, TurningAndMoving(), rig);
  EXPECT_EQ(global.p_c, point.p_c);
  EXPECT_EQ(global.z, point.z);
  rig.colour_readout_s = 0.03;
  const LiftedPoint still = CompensateRollingShutter(point, 10.0, CameraVelocity(), rig);
  EXPECT_EQ(still.p_c, point.p_c);
  EXPECT_FALSE(CompensateRollingShutter(LiftedPoint(), 10.0, TurningAndMoving(), rig).valid);
}

TEST(RollingShutterTest, RowTimesSpanTheReadoutAboutTheMiddleRow) {
  Rig rig = SyntheticRig(SyntheticSensor::kRgbd);
  rig.colour_readout_s = 0.024;
  const int h = rig.colour.height;
  EXPECT_NEAR(rig.RowTimeOffset(-0.5), -0.012, 1e-15);
  EXPECT_NEAR(rig.RowTimeOffset(h - 0.5), 0.012, 1e-15);
  EXPECT_NEAR(rig.RowTimeOffset(0.5 * h - 0.5), 0.0, 1e-15);
}

// Frame velocities: each step registered once, gaps and missing steps handled, a frame
// asked for again gets the velocity it got the first time.
TEST(FrameVelocitiesTest, EachStepIsRegisteredOnceAndGapsGiveNoVelocity) {
  const double dt = 1.0 / 30.0;
  // Frames 0-3 at 30 Hz, then a gap of a second before frames 4-5.
  FrameVelocities velocities({0.0, dt, 2 * dt, 3 * dt, 1.0 + 3 * dt, 1.0 + 4 * dt}, 0.1);
  std::vector<int> asked;
  CameraVelocity step_velocity;
  step_velocity.angular_rad_s = Eigen::Vector3d(0.0, 1.0, 0.0);
  auto step = [&](int later) -> std::optional<Eigen::Isometry3d> {
    asked.push_back(later);
    if (later == 3) return std::nullopt;  // frames 2 and 3 do not register
    return MotionOver(step_velocity, dt);
  };
  for (int frame : {1, 0, 2, 3, 4, 5, 1}) velocities.Of(frame, step);
  EXPECT_EQ(asked, (std::vector<int>{1, 2, 3, 5}));  // the gap's step (4) is never asked for
  EXPECT_EQ(velocities.counts().both, 1);            // frame 1
  EXPECT_EQ(velocities.counts().one, 4);             // 0, 2 (from 1), and 4 and 5 (from each other)
  EXPECT_EQ(velocities.counts().none, 1);            // 3: its steps failed or span the gap
  const auto v1 = velocities.Of(1, step);
  ASSERT_TRUE(v1);
  EXPECT_LT((v1->angular_rad_s - step_velocity.angular_rad_s).norm(), 1e-12);
  EXPECT_FALSE(velocities.Of(3, step));
  EXPECT_EQ(velocities.AngularRates().size(), 5u);
}

// Along a trajectory of every frame, each asked-for stamp's velocity comes from the poses next
// to its own; a stamp with no pose near it, or a pose with no neighbour, gets none.
TEST(FrameVelocitiesTest, VelocitiesAtStampsFollowTheTrajectory) {
  const CameraVelocity v = TurningAndMoving();
  const double dt = 1.0 / 30.0;
  Trajectory trajectory;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 6; ++i) {
    if (i != 4) trajectory.push_back({100.0 + i * dt, T});  // frame 4 was not placed
    T = T * MotionOver(v, dt);
  }
  const std::map<int, double> stamps = {
      {7, 100.0 + 1 * dt}, {9, 100.0 + 3 * dt + 2e-5}, {11, 100.0 + 5 * dt}, {12, 50.0}};
  const std::map<int, CameraVelocity> at = VelocitiesAtStamps(trajectory, stamps, 0.1, 1e-4);
  ASSERT_EQ(at.size(), 3u);  // 12 has no pose near it
  for (const int frame : {7, 9, 11}) {
    ASSERT_EQ(at.count(frame), 1u) << frame;
    EXPECT_LT((at.at(frame).angular_rad_s - v.angular_rad_s).norm(), 1e-9) << frame;
    // Exact where the neighbours are one step away (7); across the missing frame the linear
    // velocity is first order in the two steps' rotation.
    EXPECT_LT((at.at(frame).linear_m_s - v.linear_m_s).norm(), frame == 7 ? 1e-9 : 0.02) << frame;
  }
}

}  // namespace
}  // namespace ieslam
