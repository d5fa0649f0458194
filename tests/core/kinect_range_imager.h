// A Kinect v1 range imager (640 x 480, 585 px, the 7-Scenes calibration's noise model) for
// tests that render or read range images, and a rolling shutter's turn.
#pragma once

#include <Eigen/Geometry>

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
