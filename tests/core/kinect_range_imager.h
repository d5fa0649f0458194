// A Kinect v1 range imager (640 x 480, 585 px, the 7-Scenes calibration's noise model) for
// tests that render or read range images.
#pragma once

#include "core/camera.h"

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

}  // namespace testing_core
}  // namespace ieslam
