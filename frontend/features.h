// SIFT keypoints and descriptors of a colour image (paper §IV: SIFT in the colour image).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/option_table.h"

namespace ieslam {

struct FeatureOptions {
  // Upper bound on keypoints kept (strongest first); 0 keeps all.
  int max_features = 1000;
  double contrast_threshold = 0.04;  // OpenCV's default (Lowe's 0.03 on a different scale)
  double edge_threshold = 10.0;
  int octave_layers = 3;
  double sigma = 1.6;
  // SIFT runs on the image resized by this factor and keypoints are scaled back. OpenCV
  // doubles the image before the first octave, so 0.5 still starts at full resolution's
  // finest detail, and on VGA frames it keeps the registration accuracy of full resolution
  // at a fraction of the cost (docs/frontend_notes.md).
  double image_scale = 0.5;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<FeatureOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

// Keypoints of one image. Row i of `descriptors` belongs to keypoint i.
struct FrameFeatures {
  std::vector<Eigen::Vector2d> pixels;  // distorted pixel coordinates in the full image
  std::vector<float> scales;            // keypoint size (diameter) in full-image pixels
  std::vector<cv::Vec3b> colours;       // BGR at the keypoint
  // CV_8U, N x 128: OpenCV's SIFT rounds and saturates its float descriptors to integers in
  // [0, 255], so bytes hold them exactly at a quarter of the floats' memory.
  cv::Mat descriptors;

  int size() const { return static_cast<int>(pixels.size()); }
};

// Detects SIFT keypoints. A textureless image gives an empty set (no error): the caller
// decides what too few features means. The result does not depend on OpenCV's thread count.
FrameFeatures ExtractFeatures(const cv::Mat& colour_bgr, const FeatureOptions& options);

}  // namespace ieslam
