#include "backend/evaluation/error_stats.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

TEST(ErrorStats, StatsFollowNumpy) {
  const ErrorStats even = ComputeErrorStats({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(even.count, 4u);
  EXPECT_DOUBLE_EQ(even.median, 2.5);
  EXPECT_DOUBLE_EQ(even.mean, 2.5);
  EXPECT_DOUBLE_EQ(even.std, std::sqrt(1.25));  // ddof = 0
  EXPECT_DOUBLE_EQ(even.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(even.min, 1.0);
  EXPECT_DOUBLE_EQ(even.max, 4.0);
  EXPECT_DOUBLE_EQ(ComputeErrorStats({5.0, 1.0, 3.0}).median, 3.0);
}

TEST(ErrorStats, FiniteStatsSkipNaNAndInfAndAreZeroWithoutValues) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const ErrorStats stats = ComputeFiniteErrorStats({3.0, nan, 1.0, inf, 2.0});
  EXPECT_EQ(stats.count, 3u);
  EXPECT_EQ(stats.mean, 2.0);
  EXPECT_EQ(stats.rmse, std::sqrt(14.0 / 3.0));
  EXPECT_EQ(stats.median, 2.0);
  EXPECT_EQ(stats.max, 3.0);
  EXPECT_EQ(stats.min, 1.0);
  const ErrorStats none = ComputeFiniteErrorStats({nan, inf});
  EXPECT_EQ(none.count, 0u);
  EXPECT_EQ(none.rmse, 0.0);
  EXPECT_EQ(none.mean, 0.0);
  EXPECT_EQ(none.max, 0.0);
  EXPECT_EQ(ComputeFiniteErrorStats({}).count, 0u);
}

TEST(ErrorStats, ScalingChangesTheUnitButNotTheCount) {
  const ErrorStats scaled = ScaleErrorStats(ComputeErrorStats({1.0, 3.0}), 10.0);
  EXPECT_EQ(scaled.count, 2u);
  EXPECT_DOUBLE_EQ(scaled.mean, 20.0);
  EXPECT_DOUBLE_EQ(scaled.median, 20.0);
  EXPECT_DOUBLE_EQ(scaled.std, 10.0);
  EXPECT_DOUBLE_EQ(scaled.min, 10.0);
  EXPECT_DOUBLE_EQ(scaled.max, 30.0);
  EXPECT_DOUBLE_EQ(scaled.rmse, 10.0 * std::sqrt(5.0));
}

TEST(ErrorStats, MedianOfOddAndEvenCounts) {
  EXPECT_EQ(Median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_EQ(Median({4.0, 1.0, 3.0, 2.0}), 2.5);
  EXPECT_EQ(Median({7.0}), 7.0);
}

}  // namespace
}  // namespace ieslam
