#include "frontend/features.h"

#include <algorithm>
#include <numeric>
#include <tuple>

#include <glog/logging.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace ieslam {

const OptionTable<FeatureOptions>& FeatureOptions::Table() {
  static const OptionTable<FeatureOptions>* table = [] {
    using O = FeatureOptions;
    auto* t = new OptionTable<O>;
    t->Int("max_features", &O::max_features, "strongest SIFT keypoints kept per frame (0: all)")
        .Min(0);
    t->Double("contrast_threshold", &O::contrast_threshold, "SIFT's contrast threshold")
        .Above(0.0)
        .Below(1.0);
    t->Double("edge_threshold", &O::edge_threshold, "SIFT's edge threshold").Above(1.0);
    t->Int("octave_layers", &O::octave_layers, "SIFT's layers per octave").Range(1, 8);
    t->Double("image_scale", &O::image_scale,
              "SIFT on the image scaled by this (keypoints scaled back)")
        .Above(0.1)
        .Max(1.0);
    t->Double("sigma", &O::sigma, "SIFT's Gaussian at the first octave").Above(0.0);
    return t;
  }();
  return *table;
}

FrameFeatures ExtractFeatures(const cv::Mat& colour_bgr, const FeatureOptions& options) {
  CHECK_EQ(colour_bgr.type(), CV_8UC3);
  cv::Mat grey;
  cv::cvtColor(colour_bgr, grey, cv::COLOR_BGR2GRAY);
  if (options.image_scale != 1.0) {
    cv::resize(grey, grey, cv::Size(), options.image_scale, options.image_scale, cv::INTER_AREA);
  }
  // nfeatures = 0: we rank and cut ourselves below, so that ties are broken deterministically.
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(0, options.octave_layers, options.contrast_threshold,
                                            options.edge_threshold, options.sigma);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  sift->detectAndCompute(grey, cv::noArray(), keypoints, descriptors);

  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  // OpenCV merges per-thread keypoint lists, so their order depends on the thread count:
  // a total order on the keypoints' own values makes the result independent of it.
  std::sort(order.begin(), order.end(), [&keypoints](int a, int b) {
    const cv::KeyPoint& p = keypoints[a];
    const cv::KeyPoint& q = keypoints[b];
    return std::tie(q.response, p.pt.x, p.pt.y, p.size, p.angle, p.octave) <
           std::tie(p.response, q.pt.x, q.pt.y, q.size, q.angle, q.octave);
  });
  if (options.max_features > 0 && static_cast<int>(order.size()) > options.max_features) {
    order.resize(options.max_features);
  }

  FrameFeatures features;
  features.descriptors.create(static_cast<int>(order.size()), 128, CV_8U);
  const double to_full = 1.0 / options.image_scale;
  for (size_t row = 0; row < order.size(); ++row) {
    const cv::KeyPoint& kp = keypoints[order[row]];
    // Pixel centres: OpenCV's resize maps pixel centre x' to (x' + 0.5) / s - 0.5.
    const Eigen::Vector2d pixel((kp.pt.x + 0.5) * to_full - 0.5, (kp.pt.y + 0.5) * to_full - 0.5);
    features.pixels.push_back(pixel);
    features.scales.push_back(static_cast<float>(kp.size * to_full));
    const int x = std::clamp(static_cast<int>(std::lround(pixel.x())), 0, colour_bgr.cols - 1);
    const int y = std::clamp(static_cast<int>(std::lround(pixel.y())), 0, colour_bgr.rows - 1);
    features.colours.push_back(colour_bgr.at<cv::Vec3b>(y, x));
    cv::Mat bytes = features.descriptors.row(static_cast<int>(row));
    descriptors.row(order[row]).convertTo(bytes, CV_8U);
  }
  return features;
}

}  // namespace ieslam
