#include "frontend/simulation/synthetic_trajectory.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/pose.h"
#include "frontend/simulation/synthetic_dataset.h"
#include "frontend/simulation/synthetic_scene.h"

namespace ieslam {
namespace {

TEST(SyntheticTrajectoryTest, LookRotationLooksWhereAsked) {
  // Heading 90 deg, level: the optical axis is world +y, the image's down is world -z.
  const Eigen::Matrix3d R = LookRotation(M_PI / 2.0, 0.0, 0.0);
  EXPECT_LT((R.col(2) - Eigen::Vector3d::UnitY()).norm(), 1e-12);
  EXPECT_LT((R.col(1) + Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  // Pitch up 30 deg: the optical axis climbs at 30 deg; roll keeps the optical axis.
  const Eigen::Matrix3d up = LookRotation(0.0, M_PI / 6.0, 0.4);
  EXPECT_NEAR(up.col(2).z(), 0.5, 1e-12);
  EXPECT_LT((up.col(2) - LookRotation(0.0, M_PI / 6.0, 0.0).col(2)).norm(), 1e-12);
}

TEST(SyntheticTrajectoryTest, OptionsCheck) {
  std::string why;
  EXPECT_TRUE(SyntheticTrajectoryOptions().Check(&why)) << why;
  SyntheticTrajectoryOptions bad;
  bad.pitch_deg = -85.0;
  EXPECT_FALSE(bad.Check(&why));
  bad = SyntheticTrajectoryOptions();
  bad.radial_sway_m = 2.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(BuildSyntheticTrajectory(bad, 10), ConfigError);
}

TEST(SyntheticTrajectoryTest, IsAHandHeldClosedLoopInFreeSpace) {
  const SyntheticDatasetOptions options;
  const SyntheticScene scene(options.scene);
  const std::vector<Eigen::Isometry3d> poses = BuildSyntheticTrajectory(options.trajectory, 300);
  ASSERT_EQ(poses.size(), 300u);
  double max_step = 0.0, max_turn = 0.0;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Isometry3d& a = poses[i];
    const Eigen::Isometry3d& b = poses[(i + 1) % 300];  // the loop closes: 299 -> 0 is a step
    max_step = std::max(max_step, (b.translation() - a.translation()).norm());
    max_turn = std::max(max_turn, RotationAngleBetween(a.linear(), b.linear()) * 180.0 / M_PI);
    EXPECT_TRUE(scene.IsFreeSpace(a.translation(), 0.5)) << "frame " << i;
    EXPECT_NEAR((a.linear().transpose() * a.linear() - Eigen::Matrix3d::Identity()).norm(), 0,
                1e-12);
    EXPECT_NEAR(a.linear().determinant(), 1.0, 1e-12);
  }
  EXPECT_LE(max_step, 0.03);
  EXPECT_LE(max_turn, 2.0);
  EXPECT_GE(max_step, 0.01);  // it does move
  const Eigen::Isometry3d again = SyntheticTrajectoryPose(options.trajectory, 300, 300);
  EXPECT_LT((again.matrix() - poses[0].matrix()).norm(), 1e-12);
}

}  // namespace
}  // namespace ieslam
