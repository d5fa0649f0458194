#include "frontend/matcher.h"

#include <random>

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

cv::Mat RandomDescriptors(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(0.0f, 100.0f);
  cv::Mat d(n, 128, CV_32F);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < 128; ++j) d.at<float>(i, j) = value(rng);
  }
  return d;
}

// The rows of `source` in the given order, each with a little noise.
cv::Mat Perturbed(const cv::Mat& source, const std::vector<int>& rows, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 2.0f);
  cv::Mat out(static_cast<int>(rows.size()), 128, CV_32F);
  for (size_t i = 0; i < rows.size(); ++i) {
    for (int j = 0; j < 128; ++j) out.at<float>(i, j) = source.at<float>(rows[i], j) + noise(rng);
  }
  return out;
}

TEST(MatcherTest, FindsTheTrueCorrespondences) {
  const cv::Mat train = RandomDescriptors(300, 1);
  std::vector<int> rows;
  for (int i = 0; i < 300; i += 3) rows.push_back(i);
  const cv::Mat query = Perturbed(train, rows, 2);
  const std::vector<DescriptorMatch> matches = MatchDescriptors(query, train, MatchOptions());
  ASSERT_EQ(matches.size(), rows.size());
  for (const DescriptorMatch& m : matches) EXPECT_EQ(m.train, rows[m.query]);
}

TEST(MatcherTest, RatioTestRejectsAmbiguousMatches) {
  cv::Mat train = RandomDescriptors(50, 3);
  train.row(0).copyTo(train.row(1));  // two identical descriptors: ambiguous
  const cv::Mat query = Perturbed(train, {0, 5}, 4);
  const std::vector<DescriptorMatch> matches = MatchDescriptors(query, train, MatchOptions());
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0].query, 1);
  EXPECT_EQ(matches[0].train, 5);
}

TEST(MatcherTest, MutualCheckKeepsOnlyOneQueryPerTrainRow) {
  const cv::Mat train = RandomDescriptors(100, 5);
  const cv::Mat query = Perturbed(train, {7, 7, 8}, 6);  // two queries near train row 7
  MatchOptions options;
  options.ratio = 1.0;
  std::vector<DescriptorMatch> matches = MatchDescriptors(query, train, options);
  int to_seven = 0;
  for (const auto& m : matches) to_seven += m.train == 7;
  EXPECT_EQ(to_seven, 1);
  options.mutual = false;
  matches = MatchDescriptors(query, train, options);
  to_seven = 0;
  for (const auto& m : matches) to_seven += m.train == 7;
  EXPECT_EQ(to_seven, 2);
}

TEST(MatcherTest, DatabaseRanksTheFrameThatSharesMostDescriptors) {
  DatabaseOptions options;
  BaseFrameDatabase database(options);
  std::vector<cv::Mat> frames;
  for (int f = 0; f < 6; ++f) {
    frames.push_back(RandomDescriptors(200, 10 + f));
    database.Add(100 + f, frames.back());
  }
  EXPECT_EQ(database.num_frames(), 6);
  EXPECT_TRUE(database.Contains(103));
  EXPECT_FALSE(database.Contains(3));
  // The query shares 120 descriptors with frame 104 and 40 with frame 101.
  std::vector<int> rows104, rows101;
  for (int i = 0; i < 120; ++i) rows104.push_back(i);
  for (int i = 0; i < 40; ++i) rows101.push_back(i);
  cv::Mat query;
  cv::vconcat(Perturbed(frames[4], rows104, 20), Perturbed(frames[1], rows101, 21), query);
  const auto ranked = database.RankFrames(query, 3);
  ASSERT_GE(ranked.size(), 2u);
  EXPECT_EQ(ranked[0].first, 104);
  EXPECT_GE(ranked[0].second, 100);
  EXPECT_EQ(ranked[1].first, 101);
  EXPECT_GE(ranked[1].second, 30);
  // Deterministic across identically built databases.
  BaseFrameDatabase again(options);
  for (int f = 0; f < 6; ++f) again.Add(100 + f, frames[f]);
  EXPECT_EQ(again.RankFrames(query, 3), ranked);
}

cv::Mat Rounded(const cv::Mat& descriptors) {
  cv::Mat bytes;
  descriptors.convertTo(bytes, CV_8U);
  return bytes;
}

cv::Mat AsFloats(const cv::Mat& bytes) {
  cv::Mat floats;
  bytes.convertTo(floats, CV_32F);
  return floats;
}

// Bytes are matched and ranked exactly as the same values in floats, with the database past
// its first index build (more than 2048 rows) and with rows in its exact tail.
TEST(MatcherTest, BytesMatchAndRankAsTheirFloats) {
  std::vector<cv::Mat> bytes;
  BaseFrameDatabase from_bytes{DatabaseOptions()}, from_floats{DatabaseOptions()};
  for (int f = 0; f < 15; ++f) {
    bytes.push_back(Rounded(RandomDescriptors(200, 40 + f)));
    from_bytes.Add(f, bytes.back());
    from_floats.Add(f, AsFloats(bytes.back()));
  }
  std::vector<int> rows;
  for (int i = 0; i < 150; ++i) rows.push_back(i);
  cv::Mat query;
  cv::vconcat(Rounded(Perturbed(AsFloats(bytes[3]), rows, 50)),
              Rounded(Perturbed(AsFloats(bytes[14]), rows, 51)), query);
  const auto ranked = from_bytes.RankFrames(query, 4);
  ASSERT_GE(ranked.size(), 2u);
  EXPECT_EQ(ranked, from_floats.RankFrames(AsFloats(query), 4));
  EXPECT_TRUE(ranked[0].first == 3 || ranked[0].first == 14);

  const auto a = MatchDescriptors(query, bytes[3], MatchOptions());
  const auto b = MatchDescriptors(AsFloats(query), AsFloats(bytes[3]), MatchOptions());
  ASSERT_EQ(a.size(), b.size());
  EXPECT_GE(a.size(), 100u);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].query, b[i].query);
    EXPECT_EQ(a[i].train, b[i].train);
    EXPECT_EQ(a[i].distance, b[i].distance);
  }

  from_bytes.Clear();
  EXPECT_EQ(from_bytes.num_frames(), 0);
  EXPECT_FALSE(from_bytes.Contains(3));
  EXPECT_TRUE(from_bytes.RankFrames(query, 4).empty());
  from_bytes.Add(3, bytes[3]);
  ASSERT_FALSE(from_bytes.RankFrames(query, 4).empty());
  EXPECT_EQ(from_bytes.RankFrames(query, 4)[0].first, 3);
}

TEST(MatcherTest, DatabaseRejectsBadOptionsWithConfigError) {
  DatabaseOptions bad;
  bad.neighbours = 1;
  EXPECT_THROW(BaseFrameDatabase{bad}, ConfigError);
  bad = DatabaseOptions();
  bad.trees = 0;
  EXPECT_THROW(BaseFrameDatabase{bad}, ConfigError);
}

TEST(MatcherTest, EmptyInputsGiveNoMatches) {
  const cv::Mat train = RandomDescriptors(10, 7);
  EXPECT_TRUE(MatchDescriptors(cv::Mat(0, 128, CV_32F), train, MatchOptions()).empty());
  BaseFrameDatabase database{DatabaseOptions()};
  EXPECT_TRUE(database.RankFrames(train, 5).empty());
}

}  // namespace
}  // namespace ieslam
