#include "core/observation.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

PinholeCamera TestCamera() {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = 525.0;
  camera.fy = 520.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  return camera;
}

// A random pose and a random point 1-6 m in front of it.
void RandomState(std::mt19937* rng, double beta, Vector6d* T_w_c, Eigen::Vector3d* p_w) {
  std::uniform_real_distribution<double> t(-3.0, 3.0), angle(-M_PI, M_PI), lateral(-0.6, 0.6),
      depth(1.0, 6.0);
  *T_w_c << t(*rng), t(*rng), t(*rng), angle(*rng), beta, angle(*rng);
  const double d = depth(*rng);
  const Eigen::Vector3d p_c(lateral(*rng) * d, lateral(*rng) * d, d);
  *p_w = EulerZyxToRotation(T_w_c->tail<3>()) * p_c + T_w_c->head<3>();
}

// Central differences with a step that balances truncation (h^2) and rounding (eps/h).
void NumericJacobians(const Vector6d& T_w_c, const Eigen::Vector3d& p_w,
                      const PinholeCamera& camera, Matrix36d* d_pose, Eigen::Matrix3d* d_point) {
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Vector6d plus = T_w_c, minus = T_w_c;
    plus[k] += h;
    minus[k] -= h;
    d_pose->col(k) =
        (PredictObservation(plus, p_w, camera) - PredictObservation(minus, p_w, camera)) / (2 * h);
  }
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d plus = p_w, minus = p_w;
    plus[k] += h;
    minus[k] -= h;
    d_point->col(k) =
        (PredictObservation(T_w_c, plus, camera) - PredictObservation(T_w_c, minus, camera)) /
        (2 * h);
  }
}

void ExpectJacobiansMatchNumeric(const Vector6d& T_w_c, const Eigen::Vector3d& p_w) {
  const PinholeCamera camera = TestCamera();
  Matrix36d d_pose;
  Eigen::Matrix3d d_point;
  const Eigen::Vector3d z = PredictObservation(T_w_c, p_w, camera, &d_pose, &d_point);
  EXPECT_LT((z - PredictObservation(T_w_c, p_w, camera)).norm(), 1e-12)
      << "asking for Jacobians must not change the prediction";
  Matrix36d numeric_pose;
  Eigen::Matrix3d numeric_point;
  NumericJacobians(T_w_c, p_w, camera, &numeric_pose, &numeric_point);
  // Relative to each row's scale: pixel rows are ~1e2-1e3, the range row ~1.
  for (int r = 0; r < 3; ++r) {
    const double scale = std::max(1.0, numeric_pose.row(r).norm());
    EXPECT_LT((d_pose.row(r) - numeric_pose.row(r)).norm() / scale, 1e-6)
        << "pose row " << r << "\nanalytic\n"
        << d_pose << "\nnumeric\n"
        << numeric_pose;
    const double point_scale = std::max(1.0, numeric_point.row(r).norm());
    EXPECT_LT((d_point.row(r) - numeric_point.row(r)).norm() / point_scale, 1e-6)
        << "point row " << r;
  }
  // The only-one-pointer calls give the same blocks.
  Matrix36d pose_only;
  Eigen::Matrix3d point_only;
  PredictObservation(T_w_c, p_w, camera, &pose_only);
  PredictObservation(T_w_c, p_w, camera, nullptr, &point_only);
  EXPECT_EQ(pose_only, d_pose);
  EXPECT_EQ(point_only, d_point);
}

TEST(ObservationTest, PredictionIsPinholePixelAndRange) {
  const PinholeCamera camera = TestCamera();
  Vector6d T_w_c;
  T_w_c << 1.0, 2.0, 3.0, 0.0, 0.0, 0.0;
  const Eigen::Vector3d p_w(1.5, 1.0, 5.0);  // p_c = (0.5, -1, 2)
  const Eigen::Vector3d z = PredictObservation(T_w_c, p_w, camera);
  EXPECT_NEAR(z.x(), 525.0 * 0.25 + 319.5, 1e-12);
  EXPECT_NEAR(z.y(), 520.0 * -0.5 + 239.5, 1e-12);
  EXPECT_NEAR(z.z(), std::sqrt(0.25 + 1.0 + 4.0), 1e-12);
}

TEST(ObservationTest, ObservationToWorldInvertsPrediction) {
  std::mt19937 rng(7);
  const PinholeCamera camera = TestCamera();
  for (int i = 0; i < 200; ++i) {
    Vector6d T_w_c;
    Eigen::Vector3d p_w;
    RandomState(&rng, std::uniform_real_distribution<double>(-1.5, 1.5)(rng), &T_w_c, &p_w);
    const Eigen::Vector3d z = PredictObservation(T_w_c, p_w, camera);
    EXPECT_LT((ObservationToWorld(T_w_c, z, camera) - p_w).norm(), 1e-9);
  }
}

// J Q J^T with J the finite-difference Jacobian of the back-projection ObservationToWorld;
// and its two readings: sigma_d^2 along the ray, (pixel sigma * depth / f)^2 across it.
TEST(ObservationTest, BackProjectedCovarianceMatchesTheBackProjectionsJacobian) {
  std::mt19937 rng(11);
  const PinholeCamera camera = TestCamera();
  for (int i = 0; i < 50; ++i) {
    Vector6d T_w_c;
    Eigen::Vector3d p_c;
    RandomState(&rng, 0.0, &T_w_c, &p_c);
    p_c = WorldToCamera(T_w_c, p_c);
    const Eigen::Vector3d z = PredictObservation(Vector6d::Zero(), p_c, camera);
    Eigen::Matrix3d Q;
    Q << 1.3, 0.2, 0.0, 0.2, 0.8, 0.0, 0.0, 0.0, 4e-4 * (1.0 + i);
    Eigen::Matrix3d J;
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d plus = z, minus = z;
      plus[k] += h;
      minus[k] -= h;
      J.col(k) = (ObservationToWorld(Vector6d::Zero(), plus, camera) -
                  ObservationToWorld(Vector6d::Zero(), minus, camera)) /
                 (2 * h);
    }
    const Eigen::Matrix3d expected = J * Q * J.transpose();
    const Eigen::Matrix3d covariance = BackProjectedCovariance(p_c, Q, camera);
    EXPECT_LT((covariance - expected).norm(), 1e-6 * expected.norm()) << "point " << i;
  }
  // On the optical axis: the range variance along it, the scaled pixel variance across.
  const Eigen::Matrix3d Q = Eigen::Vector3d(1.0, 1.0, 0.02 * 0.02).asDiagonal();
  const Eigen::Matrix3d on_axis = BackProjectedCovariance(Eigen::Vector3d(0, 0, 2.0), Q, camera);
  EXPECT_NEAR(on_axis(2, 2), 0.02 * 0.02, 1e-15);
  EXPECT_NEAR(on_axis(0, 0), std::pow(2.0 / camera.fx, 2), 1e-15);
  EXPECT_NEAR(on_axis(1, 1), std::pow(2.0 / camera.fy, 2), 1e-15);
  EXPECT_NEAR(on_axis(0, 1), 0.0, 1e-15);
}

TEST(ObservationTest, RotationDerivativesMatchFiniteDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  for (const double beta : {0.3, 89.999 * kDeg, 90.0 * kDeg, -90.0 * kDeg}) {
    const Eigen::Vector3d abg(angle(rng), beta, angle(rng));
    const std::array<Eigen::Matrix3d, 3> dR = EulerZyxRotationDerivatives(abg);
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d plus = abg, minus = abg;
      plus[k] += 1e-6;
      minus[k] -= 1e-6;
      const Eigen::Matrix3d numeric = (EulerZyxToRotation(plus) - EulerZyxToRotation(minus)) / 2e-6;
      EXPECT_LT((dR[k] - numeric).norm(), 1e-8) << "angle " << k << " beta " << beta;
    }
  }
}

TEST(ObservationTest, JacobiansMatchFiniteDifferencesAtRandomStates) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> beta(-1.5, 1.5);
  for (int i = 0; i < 200; ++i) {
    Vector6d T_w_c;
    Eigen::Vector3d p_w;
    RandomState(&rng, beta(rng), &T_w_c, &p_w);
    ExpectJacobiansMatchNumeric(T_w_c, p_w);
  }
}

TEST(ObservationTest, JacobiansMatchFiniteDifferencesNearGimbalLock) {
  std::mt19937 rng(13);
  for (const double beta_deg : {89.999, -89.999, 90.0, -90.0, 89.9}) {
    for (int i = 0; i < 50; ++i) {
      Vector6d T_w_c;
      Eigen::Vector3d p_w;
      RandomState(&rng, beta_deg * kDeg, &T_w_c, &p_w);
      ExpectJacobiansMatchNumeric(T_w_c, p_w);
    }
  }
}

TEST(ObservationTest, GimbalLockMakesAlphaAndGammaColumnsParallel) {
  // At beta = 90 deg, alpha and gamma turn the camera about the same axis, so their
  // columns are equal up to sign: the rank loss the filter sees through the Jacobian.
  std::mt19937 rng(17);
  Vector6d T_w_c;
  Eigen::Vector3d p_w;
  RandomState(&rng, 90.0 * kDeg, &T_w_c, &p_w);
  Matrix36d d_pose;
  PredictObservation(T_w_c, p_w, TestCamera(), &d_pose);
  EXPECT_LT((d_pose.col(3) + d_pose.col(5)).norm(), 1e-9 * d_pose.col(3).norm());
}

}  // namespace
}  // namespace ieslam
