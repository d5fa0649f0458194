// A Kinect v1 range imager (640 x 480, 585 px, the 7-Scenes calibration's noise model) for
// tests that render or read range images, a plane's depth, and a rolling shutter's turn.
#pragma once

#include <array>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/range_cloud.h"

namespace ieslam {
namespace testing_core {

inline RangeImager KinectRangeImager() {
  RangeImager range;
  range.camera.width = 640;
  range.camera.height = 480;
  range.camera.fx = range.camera.fy = 585.0;
  range.camera.cx = 320.0;
  range.camera.cy = 240.0;
  range.noise = {0.0002, 0.0, 0.0016};
  return range;
}

// Depth (z) of the plane n . p = offset seen through each pixel of `range`, as an imager with
// `correction` (RangeImager::depth_correction) reads it: times the factor at the pixel; 0
// where the plane is behind.
inline cv::Mat PlaneDepth(const RangeImager& range, const Eigen::Vector3d& n, double offset,
                          const std::array<double, 3>& correction = {0.0, 0.0, 0.0}) {
  cv::Mat depth(range.camera.height, range.camera.width, CV_32FC1, cv::Scalar(0.0f));
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      const Eigen::Vector3d ray = range.camera.Unproject(Eigen::Vector2d(x, y));  // z = 1
      const double z = offset / n.dot(ray);
      if (z > 0.0) {
        depth.at<float>(y, x) = static_cast<float>(
            z * RangeImager::DepthCorrectionFactor(correction, ray.x(), ray.y()));
      }
    }
  }
  return depth;
}

// The rows' motion of a rolling shutter turning about the camera's y axis at `rate` rad/s,
// its rows read over `readout` seconds (row times centred on the frame's timestamp).
inline RangeRowMotion TurningRowMotion(const RangeImager& range, double rate, double readout) {
  return [range, rate, readout](double row) {
    const double tau = ((row + 0.5) / range.camera.height - 0.5) * readout;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(rate * tau, Eigen::Vector3d::UnitY()).toRotationMatrix();
    return T;
  };
}

}  // namespace testing_core
}  // namespace ieslam
