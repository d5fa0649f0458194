#include "frontend/registration.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Cholesky>

#include <gtest/gtest.h>

#include "core/pose.h"

namespace ieslam {
namespace {

struct Scene {
  std::vector<Eigen::Vector3d> a, b;
  Eigen::Isometry3d T_a_b;
};

// Points in a 2 m box seen from two poses, with Gaussian noise and a fraction of outliers.
Scene MakeScene(int n, double noise, double outlier_fraction, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> box(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, noise);
  Scene scene;
  Vector6d pose;
  pose << 0.3, -0.1, 0.2, 0.2, -0.1, 0.15;
  scene.T_a_b = PoseToIsometry(pose);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p_b(box(rng), box(rng), 2.0 + box(rng));
    Eigen::Vector3d p_a = scene.T_a_b * p_b;
    if (i < outlier_fraction * n) p_a = Eigen::Vector3d(box(rng), box(rng), 2.0 + box(rng));
    scene.a.push_back(p_a + Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)));
    scene.b.push_back(p_b);
  }
  return scene;
}

double TranslationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

TEST(RegistrationTest, RecoversThePoseExactlyWithoutNoise) {
  const Scene scene = MakeScene(100, 0.0, 0.0, 1);
  const RegistrationResult result = RegisterPointSets(scene.a, scene.b, RegistrationOptions());
  ASSERT_TRUE(result.success) << result.reason;
  EXPECT_LT(TranslationError(result.T_a_b, scene.T_a_b), 1e-9);
  EXPECT_LT(RotationAngleBetween(result.T_a_b.linear(), scene.T_a_b.linear()), 1e-9);
  EXPECT_EQ(result.inliers.size(), 100u);
  EXPECT_NEAR(result.rms_m, 0.0, 1e-9);
}

TEST(RegistrationTest, HalfOutliersStillRegisterWithinNoise) {
  const Scene scene = MakeScene(200, 0.003, 0.5, 2);
  const RegistrationResult result = RegisterPointSets(scene.a, scene.b, RegistrationOptions());
  ASSERT_TRUE(result.success) << result.reason;
  EXPECT_LT(TranslationError(result.T_a_b, scene.T_a_b), 0.003);
  EXPECT_LT(RotationAngleBetween(result.T_a_b.linear(), scene.T_a_b.linear()), 0.003);
  // Every true correspondence is an inlier; almost no outlier is.
  int true_inliers = 0;
  for (int i : result.inliers) true_inliers += i >= 100;
  EXPECT_EQ(true_inliers, 100);
  EXPECT_LE(result.inliers.size(), 103u);
  EXPECT_NEAR(result.inlier_ratio, result.inliers.size() / 200.0, 1e-12);
}

// The pose returned is the least-squares fit to the inliers returned, also when that fit
// leaves a few of RANSAC's inliers just past the threshold (a tight threshold, 2 sigma per
// axis, makes that common): RANSAC's three-point model must not be returned instead.
TEST(RegistrationTest, ThePoseIsTheLeastSquaresFitToItsInliers) {
  for (uint32_t seed = 10; seed < 20; ++seed) {
    const Scene scene = MakeScene(200, 0.02, 0.3, seed);
    RegistrationOptions options;
    options.inlier_threshold_m = 0.04;
    const RegistrationResult result = RegisterPointSets(scene.a, scene.b, options);
    ASSERT_TRUE(result.success) << result.reason;
    std::vector<Eigen::Vector3d> a, b;
    for (int i : result.inliers) {
      a.push_back(scene.a[i]);
      b.push_back(scene.b[i]);
    }
    options.inlier_threshold_m = 1.0;  // every one of them: the fit is Arun's on all
    const RegistrationResult least_squares = RegisterPointSets(a, b, options);
    ASSERT_TRUE(least_squares.success) << least_squares.reason;
    EXPECT_LT((result.T_a_b.matrix() - least_squares.T_a_b.matrix()).norm(), 1e-9)
        << "seed " << seed;
  }
}

TEST(RegistrationTest, SameSeedSameResultDifferentSeedStillCorrect) {
  const Scene scene = MakeScene(150, 0.005, 0.4, 3);
  RegistrationOptions options;
  const RegistrationResult first = RegisterPointSets(scene.a, scene.b, options);
  const RegistrationResult again = RegisterPointSets(scene.a, scene.b, options);
  EXPECT_EQ(first.T_a_b.matrix(), again.T_a_b.matrix());
  EXPECT_EQ(first.inliers, again.inliers);
  options.seed = 777;
  const RegistrationResult other = RegisterPointSets(scene.a, scene.b, options);
  ASSERT_TRUE(other.success);
  EXPECT_LT(TranslationError(other.T_a_b, scene.T_a_b), 0.005);
}

TEST(RegistrationTest, RefusesTooFewCorrespondences) {
  const Scene scene = MakeScene(8, 0.0, 0.0, 4);
  const RegistrationResult result = RegisterPointSets(scene.a, scene.b, RegistrationOptions());
  EXPECT_FALSE(result.success);
  EXPECT_NE(result.reason.find("too few"), std::string::npos) << result.reason;
}

TEST(RegistrationTest, RefusesCollinearPoints) {
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 50; ++i) {
    b.emplace_back(0.02 * i, 0.0, 2.0);
    a.push_back(b.back() + Eigen::Vector3d(0.1, 0.0, 0.0));
  }
  const RegistrationResult result = RegisterPointSets(a, b, RegistrationOptions());
  EXPECT_FALSE(result.success);
  EXPECT_NE(result.reason.find("degenerate"), std::string::npos) << result.reason;
}

TEST(RegistrationTest, RefusesATinyPatch) {
  Scene scene = MakeScene(60, 0.0, 0.0, 5);
  for (auto& p : scene.b) p = Eigen::Vector3d(0, 0, 2) + 0.005 * p;
  for (size_t i = 0; i < scene.a.size(); ++i) scene.a[i] = scene.T_a_b * scene.b[i];
  const RegistrationResult result = RegisterPointSets(scene.a, scene.b, RegistrationOptions());
  EXPECT_FALSE(result.success);
  EXPECT_NE(result.reason.find("degenerate"), std::string::npos) << result.reason;
}

// A range imager's noise: sigma_d = 0.0075 d^2 along each point's ray (1.5 cm at ~1.4 m,
// 12 cm at 4 m, Kinect-like), one pixel (f = 525) across it.
Eigen::Matrix3d RangeImagerCovariance(const Eigen::Vector3d& p) {
  const Eigen::Vector3d ray = p.normalized();
  const double d = p.norm();
  const double sigma_d = 0.0075 * d * d, sigma_across = d / 525.0;
  const Eigen::Matrix3d along = ray * ray.transpose();
  return sigma_d * sigma_d * along +
         sigma_across * sigma_across * (Eigen::Matrix3d::Identity() - along);
}

struct NoisyScene {
  std::vector<Eigen::Vector3d> a, b;
  std::vector<Eigen::Matrix3d> covariances_a, covariances_b;
  Eigen::Isometry3d T_a_b;
};

// Points 1-4 m in front of camera b, seen by a camera 20 cm and ~8 deg away; each point
// drawn with its own camera's range-imager noise.
NoisyScene MakeNoisyScene(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-0.5, 0.5), depth(1.0, 4.0);
  std::normal_distribution<double> gauss;
  auto draw = [&](const Eigen::Vector3d& p, const Eigen::Matrix3d& covariance) {
    const Eigen::Matrix3d L = Eigen::LLT<Eigen::Matrix3d>(covariance).matrixL();
    return Eigen::Vector3d(p + L * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)));
  };
  NoisyScene scene;
  Vector6d pose;
  pose << 0.15, -0.05, 0.1, 0.1, -0.05, 0.08;
  scene.T_a_b = PoseToIsometry(pose);
  for (int i = 0; i < n; ++i) {
    const double d = depth(rng);
    const Eigen::Vector3d p_b(lateral(rng) * d, lateral(rng) * d, d);
    const Eigen::Vector3d p_a = scene.T_a_b * p_b;
    scene.covariances_a.push_back(RangeImagerCovariance(p_a));
    scene.covariances_b.push_back(RangeImagerCovariance(p_b));
    scene.a.push_back(draw(p_a, scene.covariances_a.back()));
    scene.b.push_back(draw(p_b, scene.covariances_b.back()));
  }
  return scene;
}

// An isotropic gate wide enough for the range noise: 3 sigma of two points' difference at
// 2 m (sigma_d 3 cm each).
RegistrationOptions WideIsotropicGate() {
  RegistrationOptions options;
  options.inlier_threshold_m = 3.0 * std::sqrt(2.0) * 0.0075 * 4.0;
  return options;
}

// Far points' range noise is ~16 times near points'; weighting each by its covariance must
// beat the unweighted fit clearly. Over 20 draws the RMS pose error of the weighted fit is
// compared with the unweighted one's, which it must beat by a wide margin
// (docs/frontend_notes.md).
TEST(RegistrationTest, WeightingByCovarianceBeatsTheUnweightedFit) {
  double weighted_t2 = 0.0, unweighted_t2 = 0.0, weighted_r2 = 0.0, unweighted_r2 = 0.0;
  for (uint32_t seed = 100; seed < 120; ++seed) {
    const NoisyScene scene = MakeNoisyScene(150, seed);
    const RegistrationOptions options = WideIsotropicGate();
    const RegistrationResult unweighted = RegisterPointSets(scene.a, scene.b, options);
    const RegistrationResult weighted =
        RegisterPointSets(scene.a, scene.b, scene.covariances_a, scene.covariances_b, options);
    ASSERT_TRUE(unweighted.success) << unweighted.reason;
    ASSERT_TRUE(weighted.success) << weighted.reason;
    unweighted_t2 += std::pow(TranslationError(unweighted.T_a_b, scene.T_a_b), 2);
    weighted_t2 += std::pow(TranslationError(weighted.T_a_b, scene.T_a_b), 2);
    unweighted_r2 +=
        std::pow(RotationAngleBetween(unweighted.T_a_b.linear(), scene.T_a_b.linear()), 2);
    weighted_r2 += std::pow(RotationAngleBetween(weighted.T_a_b.linear(), scene.T_a_b.linear()), 2);
  }
  EXPECT_LT(std::sqrt(weighted_t2 / unweighted_t2), 0.4);
  EXPECT_LT(std::sqrt(weighted_r2 / unweighted_r2), 0.5);
}

// With every covariance the same, the weighted fit is the least-squares fit (Arun's).
TEST(RegistrationTest, EqualCovariancesGiveTheLeastSquaresFit) {
  const Scene scene = MakeScene(120, 0.01, 0.0, 6);
  const std::vector<Eigen::Matrix3d> same(scene.a.size(), 1e-4 * Eigen::Matrix3d::Identity());
  RegistrationOptions options;
  options.inlier_threshold_m = 1.0;
  options.inlier_chi2 = 1e6;  // everything is an inlier of both
  const RegistrationResult unweighted = RegisterPointSets(scene.a, scene.b, options);
  const RegistrationResult weighted = RegisterPointSets(scene.a, scene.b, same, same, options);
  ASSERT_TRUE(weighted.success) << weighted.reason;
  EXPECT_EQ(weighted.inliers.size(), scene.a.size());
  EXPECT_LT(TranslationError(weighted.T_a_b, unweighted.T_a_b), 1e-8);
  EXPECT_LT(RotationAngleBetween(weighted.T_a_b.linear(), unweighted.T_a_b.linear()), 1e-8);
}

// Wrong associations 20-25 pixels off (4-5 cm across the ray at ~1.8 m, 7-9 lateral sigmas
// of the difference) pass the isotropic gate sized for the range noise, but not the
// Mahalanobis one; the true matches stay (r^T S^-1 r is chi-square 3 for them: their mean
// is near 3).
TEST(RegistrationTest, TheMahalanobisGateRejectsWhatTheIsotropicGateLetsThrough) {
  NoisyScene scene = MakeNoisyScene(200, 7);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> offset(0.04, 0.05), angle(-M_PI, M_PI);
  const int wrong = 12;
  int placed = 0;
  for (size_t i = 0; i < scene.a.size() && placed < wrong; ++i) {
    const double d = scene.a[i].norm();
    if (d < 1.7 || d > 2.0) continue;
    // Move a_i sideways, across its ray, keeping its range: another feature nearby.
    const Eigen::Vector3d ray = scene.a[i].normalized();
    const Eigen::Vector3d u = ray.unitOrthogonal(), v = ray.cross(u);
    const double phi = angle(rng);
    scene.a[i] += offset(rng) * (std::cos(phi) * u + std::sin(phi) * v);
    std::swap(scene.a[i], scene.a[placed]);
    std::swap(scene.b[i], scene.b[placed]);
    std::swap(scene.covariances_a[i], scene.covariances_a[placed]);
    std::swap(scene.covariances_b[i], scene.covariances_b[placed]);
    ++placed;
  }
  ASSERT_EQ(placed, wrong);
  const RegistrationOptions options = WideIsotropicGate();
  const RegistrationResult isotropic = RegisterPointSets(scene.a, scene.b, options);
  const RegistrationResult mahalanobis =
      RegisterPointSets(scene.a, scene.b, scene.covariances_a, scene.covariances_b, options);
  ASSERT_TRUE(isotropic.success) << isotropic.reason;
  ASSERT_TRUE(mahalanobis.success) << mahalanobis.reason;
  auto count_wrong = [wrong](const std::vector<int>& inliers) {
    return std::count_if(inliers.begin(), inliers.end(), [wrong](int i) { return i < wrong; });
  };
  EXPECT_EQ(count_wrong(isotropic.inliers), wrong) << "the test's wrong matches must pass the "
                                                      "isotropic gate";
  EXPECT_EQ(count_wrong(mahalanobis.inliers), 0);
  // Of the 188 true matches the 0.999 gate may drop one or two by chance.
  EXPECT_GE(mahalanobis.inliers.size(), 186u);
  EXPECT_GT(mahalanobis.mean_chi2, 2.5);
  EXPECT_LT(mahalanobis.mean_chi2, 3.5);
}

TEST(RegistrationTest, OptionsAreChecked) {
  RegistrationOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why));
  options.inlier_threshold_m = 0.0;
  EXPECT_FALSE(options.Check(&why));
  options = RegistrationOptions();
  options.min_inliers = 2;
  EXPECT_FALSE(options.Check(&why));
  options = RegistrationOptions();
  options.inlier_chi2 = 0.0;
  EXPECT_FALSE(options.Check(&why));
}

}  // namespace
}  // namespace ieslam
