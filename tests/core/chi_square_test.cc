#include "core/chi_square.h"

#include <gtest/gtest.h>

namespace ieslam {
namespace {

TEST(ChiSquareTest, NormalQuantilesMatchTables) {
  EXPECT_NEAR(NormalQuantile(0.5), 0.0, 1e-9);
  EXPECT_NEAR(NormalQuantile(0.975), 1.959964, 1e-6);
  EXPECT_NEAR(NormalQuantile(0.001), -3.090232, 1e-6);
}

TEST(ChiSquareTest, QuantilesMatchTables) {
  // Reference values from standard chi-square tables.
  EXPECT_NEAR(ChiSquareQuantile(0.975, 6), 14.449, 0.1);
  EXPECT_NEAR(ChiSquareQuantile(0.025, 6), 1.237, 0.035);  // the approximation is worst here
  EXPECT_NEAR(ChiSquareQuantile(0.975, 120), 152.211, 0.1);
  EXPECT_NEAR(ChiSquareQuantile(0.025, 120), 91.573, 0.1);
  EXPECT_NEAR(ChiSquareQuantile(0.5, 100), 99.334, 0.05);
}

}  // namespace
}  // namespace ieslam
