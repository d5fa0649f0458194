#include "backend/evaluation/consistency.h"

#include <random>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

TEST(ConsistencyTest, ChiSquareQuantilesMatchTables) {
  // Reference values from standard chi-square tables.
  EXPECT_NEAR(ChiSquareQuantile(0.975, 6), 14.449, 0.1);
  EXPECT_NEAR(ChiSquareQuantile(0.025, 6), 1.237, 0.035);  // the approximation is worst here
  EXPECT_NEAR(ChiSquareQuantile(0.975, 120), 152.211, 0.1);
  EXPECT_NEAR(ChiSquareQuantile(0.025, 120), 91.573, 0.1);
  EXPECT_NEAR(ChiSquareQuantile(0.5, 100), 99.334, 0.05);
}

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

}  // namespace
}  // namespace ieslam
