#include "frontend/features.h"

#include <random>

#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace ieslam {
namespace {

// A 640 x 480 image of random discs and rectangles: texture SIFT locks onto.
cv::Mat TexturedImage(uint32_t seed) {
  cv::Mat image(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(0, 639), y(0, 479), r(3, 25), c(0, 255);
  for (int i = 0; i < 400; ++i) {
    const cv::Scalar colour(c(rng), c(rng), c(rng));
    if (i % 2 == 0) {
      cv::circle(image, {x(rng), y(rng)}, r(rng), colour, cv::FILLED, cv::LINE_AA);
    } else {
      const cv::Point corner(x(rng), y(rng));
      cv::rectangle(image, corner, corner + cv::Point(r(rng), r(rng)), colour, cv::FILLED);
    }
  }
  return image;
}

TEST(FeaturesTest, FindsKeypointsInTextureAndNoneInAFlatImage) {
  const FrameFeatures features = ExtractFeatures(TexturedImage(1), FeatureOptions());
  EXPECT_GT(features.size(), 200);
  EXPECT_LE(features.size(), FeatureOptions().max_features);
  EXPECT_EQ(features.descriptors.rows, features.size());
  EXPECT_EQ(features.descriptors.cols, 128);
  EXPECT_EQ(features.descriptors.type(), CV_8U);
  ASSERT_EQ(features.scales.size(), features.pixels.size());
  ASSERT_EQ(features.colours.size(), features.pixels.size());
  for (const Eigen::Vector2d& p : features.pixels) {
    EXPECT_GE(p.x(), -0.5);
    EXPECT_LT(p.x(), 639.5);
    EXPECT_GE(p.y(), -0.5);
    EXPECT_LT(p.y(), 479.5);
  }
  const cv::Mat flat(480, 640, CV_8UC3, cv::Scalar(90, 90, 90));
  EXPECT_EQ(ExtractFeatures(flat, FeatureOptions()).size(), 0);
}

// The bytes lose nothing: OpenCV's own float descriptors of the image are integers in
// [0, 255]. If an OpenCV release changed that, matching on the bytes would differ from
// matching on its floats, and this fails.
TEST(FeaturesTest, SiftFloatDescriptorsAreBytes) {
  cv::Mat grey;
  cv::cvtColor(TexturedImage(4), grey, cv::COLOR_BGR2GRAY);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat floats;
  const FeatureOptions options;
  cv::SIFT::create(0, options.octave_layers, options.contrast_threshold, options.edge_threshold,
                   options.sigma)
      ->detectAndCompute(grey, cv::noArray(), keypoints, floats);
  ASSERT_EQ(floats.type(), CV_32F);
  ASSERT_GT(floats.rows, 200);
  cv::Mat bytes, back;
  floats.convertTo(bytes, CV_8U);
  bytes.convertTo(back, CV_32F);
  EXPECT_EQ(cv::norm(floats, back, cv::NORM_INF), 0.0);
  double max_value = 0.0;
  cv::minMaxLoc(floats, nullptr, &max_value);
  EXPECT_GT(max_value, 1.0);  // not normalised to unit length
}

TEST(FeaturesTest, TheSameImageGivesTheSameFeatures) {
  const cv::Mat image = TexturedImage(2);
  const FrameFeatures a = ExtractFeatures(image, FeatureOptions());
  const FrameFeatures b = ExtractFeatures(image, FeatureOptions());
  ASSERT_EQ(a.size(), b.size());
  for (int i = 0; i < a.size(); ++i) EXPECT_EQ(a.pixels[i], b.pixels[i]) << i;
  EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_INF), 0.0);
}

TEST(FeaturesTest, MaxFeaturesBoundsTheCountAndImageScaleKeepsFullImageCoordinates) {
  FeatureOptions few;
  few.max_features = 50;
  EXPECT_EQ(ExtractFeatures(TexturedImage(3), few).size(), 50);
  FeatureOptions full;
  full.image_scale = 1.0;
  const FrameFeatures at_full = ExtractFeatures(TexturedImage(3), full);
  const FrameFeatures at_half = ExtractFeatures(TexturedImage(3), FeatureOptions());
  ASSERT_GT(at_full.size(), 50);
  ASSERT_GT(at_half.size(), 50);
  // Both in the full image's pixels: their spreads match.
  double max_full = 0.0, max_half = 0.0;
  for (const auto& p : at_full.pixels) max_full = std::max(max_full, p.x());
  for (const auto& p : at_half.pixels) max_half = std::max(max_half, p.x());
  EXPECT_GT(max_half, 0.9 * max_full);
}

TEST(FeaturesTest, OptionsAreChecked) {
  FeatureOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why));
  options.image_scale = 0.05;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("image_scale"), std::string::npos);
  options = FeatureOptions();
  options.octave_layers = 0;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("octave_layers"), std::string::npos);
}

}  // namespace
}  // namespace ieslam
