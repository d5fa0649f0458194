#include "core/pose.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

Vector6d RandomPose(std::mt19937* rng) {
  std::uniform_real_distribution<double> t(-5.0, 5.0), angle(-M_PI, M_PI),
      beta(-M_PI / 2 + 0.01, M_PI / 2 - 0.01);
  Vector6d pose;
  pose << t(*rng), t(*rng), t(*rng), angle(*rng), beta(*rng), angle(*rng);
  return pose;
}

TEST(PoseTest, EulerZyxIsYawPitchRollInThatOrder) {
  const Eigen::Vector3d abg(0.3, -0.2, 0.7);
  const Eigen::Matrix3d expected =
      (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
       Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()).toRotationMatrix() *
       Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitX()).toRotationMatrix());
  EXPECT_LT((EulerZyxToRotation(abg) - expected).norm(), 1e-15);
  // A pure yaw of 90 degrees turns x into y.
  EXPECT_LT(
      (EulerZyxToRotation({M_PI / 2, 0, 0}) * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY())
          .norm(),
      1e-15);
}

TEST(PoseTest, RotationEulerRoundTripAwayFromGimbalLock) {
  std::mt19937 rng(1);
  for (int i = 0; i < 1000; ++i) {
    const Vector6d pose = RandomPose(&rng);
    const Eigen::Vector3d back = RotationToEulerZyx(EulerZyxToRotation(pose.tail<3>()));
    EXPECT_LT(PoseDifference((Vector6d() << 0, 0, 0, back).finished(),
                             (Vector6d() << 0, 0, 0, pose.tail<3>()).finished())
                  .norm(),
              1e-9);
  }
}

TEST(PoseTest, QuaternionAndIsometryRoundTrips) {
  std::mt19937 rng(2);
  for (int i = 0; i < 200; ++i) {
    const Vector6d pose = RandomPose(&rng);
    const Eigen::Quaterniond q = EulerZyxToQuaternion(pose.tail<3>());
    EXPECT_NEAR(q.norm(), 1.0, 1e-14);
    EXPECT_LT((q.toRotationMatrix() - EulerZyxToRotation(pose.tail<3>())).norm(), 1e-14);
    EXPECT_LT((QuaternionToEulerZyx(q) - pose.tail<3>()).norm(), 1e-9);
    EXPECT_LT(PoseDifference(IsometryToPose(PoseToIsometry(pose)), pose).norm(), 1e-9);
  }
}

TEST(PoseTest, NearGimbalLockTheRotationSurvivesTheRoundTrip) {
  // At beta = +-90 deg only alpha -+ gamma is defined; the decomposition must still
  // reproduce the rotation matrix, and a beta just off the singularity keeps its sign.
  for (double beta : {90.0, -90.0, 89.9999, -89.9999, 90.0 - 1e-9}) {
    for (double alpha : {-170.0, -30.0, 0.0, 45.0, 179.0}) {
      for (double gamma : {-120.0, 0.0, 10.0, 175.0}) {
        const Eigen::Vector3d abg(alpha * kDeg, beta * kDeg, gamma * kDeg);
        const Eigen::Matrix3d R = EulerZyxToRotation(abg);
        const Eigen::Vector3d back = RotationToEulerZyx(R);
        EXPECT_LT((EulerZyxToRotation(back) - R).norm(), 1e-7)
            << "alpha " << alpha << " beta " << beta << " gamma " << gamma;
        EXPECT_NEAR(back[1], abg[1], 1e-6);
        EXPECT_LE(std::abs(back[1]), M_PI / 2 + 1e-12);
      }
    }
  }
}

TEST(PoseTest, ExactGimbalLockPutsTheRotationIntoAlpha) {
  const Eigen::Vector3d back = RotationToEulerZyx(EulerZyxToRotation({0.5, M_PI / 2, 0.2}));
  EXPECT_DOUBLE_EQ(back[2], 0.0);
  EXPECT_NEAR(back[0], 0.5 - 0.2, 1e-9);  // beta = +90: only alpha - gamma is observable
  const Eigen::Vector3d down = RotationToEulerZyx(EulerZyxToRotation({0.5, -M_PI / 2, 0.2}));
  EXPECT_NEAR(down[0], 0.5 + 0.2, 1e-9);  // beta = -90: only alpha + gamma
}

TEST(PoseTest, ComposeInverseAndRelativeAgreeWithIsometries) {
  std::mt19937 rng(3);
  for (int i = 0; i < 100; ++i) {
    const Vector6d a = RandomPose(&rng), b = RandomPose(&rng);
    const Eigen::Isometry3d Ta = PoseToIsometry(a), Tb = PoseToIsometry(b);
    EXPECT_LT((PoseToIsometry(ComposePoses(a, b)).matrix() - (Ta * Tb).matrix()).norm(), 1e-9);
    EXPECT_LT((PoseToIsometry(InversePose(a)).matrix() - Ta.inverse().matrix()).norm(), 1e-9);
    // Composing a with the relative pose a->b lands on b.
    EXPECT_LT(PoseDifference(ComposePoses(a, RelativePose(a, b)), b).norm(), 1e-9);
    EXPECT_LT(PoseDifference(ComposePoses(a, InversePose(a)), Vector6d::Zero()).norm(), 1e-9);
  }
}

TEST(PoseTest, WrapAngleAndPoseDifference) {
  EXPECT_NEAR(WrapAngle(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(WrapAngle(-M_PI), M_PI, 1e-12);  // (-pi, pi]
  EXPECT_NEAR(WrapAngle(0.1 - 4 * M_PI), 0.1, 1e-12);
  Vector6d a = Vector6d::Zero(), b = Vector6d::Zero();
  a[3] = M_PI - 0.01;
  b[3] = -M_PI + 0.01;
  EXPECT_NEAR(PoseDifference(a, b)[3], -0.02, 1e-12);  // across the wrap, not 2 pi - 0.02
}

TEST(PoseTest, RotationAngleBetween) {
  const Eigen::Matrix3d R = EulerZyxToRotation({0.2, 0.1, -0.3});
  EXPECT_NEAR(RotationAngleBetween(R, R), 0.0, 1e-7);
  const Eigen::Matrix3d turned =
      R * Eigen::AngleAxisd(0.25, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_NEAR(RotationAngleBetween(R, turned), 0.25, 1e-12);
}

}  // namespace
}  // namespace ieslam
