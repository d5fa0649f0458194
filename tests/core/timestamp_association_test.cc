#include "core/timestamp_association.h"

#include <cstddef>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

std::pair<std::size_t, std::size_t> Indices(const StampMatch& match) {
  return {match.first_index, match.second_index};
}

std::pair<std::size_t, std::size_t> Pair(std::size_t a, std::size_t b) { return {a, b}; }

TEST(TimestampAssociation, AssociationIsGreedyOnSmallestDifference) {
  // a[1] is closer to b[0] than a[0] is, so a[0] stays unmatched (associate.py's rule).
  auto m = AssociateStamps({0.0, 0.012, 0.05}, {0.010, 0.049, 0.2}, 0.0, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(Indices(m[0]), Pair(1, 0));
  EXPECT_EQ(Indices(m[1]), Pair(2, 1));
  // Each timestamp is used once, and differences must be strictly below the limit.
  m = AssociateStamps({1.0, 1.0012}, {1.0005, 1.0212}, 0.0, 0.02);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(Indices(m[0]), Pair(0, 0));
}

TEST(TimestampAssociation, AssociationIsGreedyByTimeDifference) {
  // (1.01, 1.012) is the closest candidate, so 1.0 falls back to 1.004.
  std::vector<StampMatch> m = AssociateStamps({1.0, 1.01}, {1.004, 1.012}, 0.0, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].first_index, 0u);
  EXPECT_EQ(m[0].second_index, 0u);
  EXPECT_EQ(m[1].first_index, 1u);
  EXPECT_EQ(m[1].second_index, 1u);
  // One second stamp wanted by two first stamps: the closer one gets it, the other none.
  m = AssociateStamps({1.0, 1.01}, {1.008}, 0.0, 0.02);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].first_index, 1u);
  EXPECT_DOUBLE_EQ(m[0].second_stamp, 1.008);
}

TEST(TimestampAssociation, AssociationAppliesOffsetAndMaxDiff) {
  const std::vector<double> first = {2.0, 2.1, 2.2, 2.3};
  const std::vector<double> second = {1.0, 1.115, 1.19, 1.33};
  // Offset 1 s: |a - (b + 1)| = 0, 0.015, 0.01, 0.03; the last is beyond 0.02.
  std::vector<StampMatch> m = AssociateStamps(first, second, 1.0, 0.02);
  ASSERT_EQ(m.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(m[i].first_index, i);
    EXPECT_EQ(m[i].second_index, i);
  }
  EXPECT_EQ(AssociateStamps(first, second, 1.0, 0.012).size(), 2u);  // drops 2.1 <-> 1.115
  EXPECT_EQ(AssociateStamps(first, second, 1.0, 0.05).size(), 4u);
  EXPECT_TRUE(AssociateStamps(first, second, 0.0, 0.02).empty());
}

TEST(TimestampAssociation, EqualDifferencesGoToTheSmallerStampsAndTheResultIsSortedByFirst) {
  // 1.0 and 1.02 are both 0.01 from 1.01: the tie goes to the smaller first stamp, and 1.02
  // then takes 1.03 (also 0.01 away). The result is in the order of the first list although
  // 1.02's match was taken second.
  const std::vector<StampMatch> m = AssociateStamps({1.0, 1.02}, {1.01, 1.03}, 0.0, 0.015);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(Indices(m[0]), Pair(0, 0));
  EXPECT_EQ(Indices(m[1]), Pair(1, 1));
  EXPECT_DOUBLE_EQ(m[1].first_stamp, 1.02);
  EXPECT_DOUBLE_EQ(m[1].second_stamp, 1.03);
}

}  // namespace
}  // namespace ieslam
