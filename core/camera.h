// Sensor models: the colour camera, the range imager, and the rig that holds both.
//
// The paper's package is a colour camera next to a time-of-flight range imager, each with
// its own intrinsics, and a calibrated rigid transform between them. A Kinect-style RGB-D
// camera whose depth is registered to colour is the special case of identity extrinsics
// and shared intrinsics (Rig::registered).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ieslam {

// Pinhole camera with OpenCV's 5-parameter distortion (k1, k2, p1, p2, k3).
// Camera frame: x right, y down, z forward (optical axis).
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  std::array<double, 5> distortion{};  // k1, k2, p1, p2, k3

  bool Check(std::string* why) const;
  bool HasDistortion() const {
    for (double d : distortion) {
      if (d != 0.0) return true;
    }
    return false;
  }
  Eigen::Matrix3d K() const;

  // Normalised image coordinates (x/z, y/z) through the distortion model and back. Defined
  // here, as Project, so that the per-point loops of the dense alignment inline them.
  Eigen::Vector2d Distort(const Eigen::Vector2d& n) const {
    const auto& [k1, k2, p1, p2, k3] = distortion;
    const double x = n.x(), y = n.y();
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
  }
  // Inverse of Distort by fixed-point iteration (as cv::undistortPoints); exact to ~1e-12
  // for the distortions of real lenses inside the image.
  Eigen::Vector2d Undistort(const Eigen::Vector2d& distorted) const;

  // Pixel of a point in the camera frame (z > 0 is the caller's business).
  Eigen::Vector2d Project(const Eigen::Vector3d& p_c) const {
    Eigen::Vector2d n(p_c.x() / p_c.z(), p_c.y() / p_c.z());
    if (HasDistortion()) n = Distort(n);
    return {fx * n.x() + cx, fy * n.y() + cy};
  }
  // The bearing ray through a pixel, scaled so that its z component is 1.
  Eigen::Vector3d Unproject(const Eigen::Vector2d& pixel) const;
  bool InImage(const Eigen::Vector2d& pixel, double border = 0.0) const;
};

// Range noise: sigma_d(d) = a + b*d + c*d^2 metres at measured range d (Kinect-style
// sensors grow quadratically, time-of-flight imagers roughly linearly).
struct RangeNoiseModel {
  double a = 0.0;
  double b = 0.0;
  double c = 0.0;
  double Sigma(double range_m) const { return a + b * range_m + c * range_m * range_m; }
};

// What a range pixel holds: the z coordinate (Kinect, TUM, 7-Scenes) or the distance
// along the pixel's ray (time-of-flight imagers such as the SwissRanger).
enum class DepthKind { kZ, kRadial };

struct RangeImager {
  PinholeCamera camera;        // intrinsics and resolution of the range image
  double depth_scale = 0.001;  // metres per raw 16-bit unit
  DepthKind depth_kind = DepthKind::kZ;
  std::vector<int> invalid_values{0};  // raw values that mean "no measurement"
  double min_range_m = 0.1;
  double max_range_m = 10.0;  // the non-ambiguity range for time-of-flight
  RangeNoiseModel noise;
  // A systematic range error that varies over the image (a structured-light sensor's depth
  // "tilt" from its projector's and camera's calibration, and a bowl): the imager reads a
  // pixel's true value times DepthCorrectionFactor(x, y) = 1 + a x + b y + c (x^2 + y^2),
  // (x, y) the pixel's undistorted normalised coordinates. Datasets divide it out as they load
  // a range image (RangeImageToMetres). All 0: none. The refinement estimates it
  // (backend/depth_correction.h).
  std::array<double, 3> depth_correction{};  // a, b, c
  // What Check allows of it: each coefficient within +-kMaxDepthCorrectionCoefficient, and the
  // factor within [kMinDepthCorrectionFactor, kMaxDepthCorrectionFactor] over the image (a
  // correction that halves or doubles a reading is no calibration).
  static constexpr double kMaxDepthCorrectionCoefficient = 0.5;
  static constexpr double kMinDepthCorrectionFactor = 0.5;
  static constexpr double kMaxDepthCorrectionFactor = 2.0;

  bool Check(std::string* why) const;
  bool HasDepthCorrection() const {
    return depth_correction[0] != 0.0 || depth_correction[1] != 0.0 || depth_correction[2] != 0.0;
  }
  // 1 + a x + b y + c (x^2 + y^2) of `coefficients` (a, b, c).
  static double DepthCorrectionFactor(const std::array<double, 3>& coefficients, double x,
                                      double y) {
    const auto& [a, b, c] = coefficients;
    return 1.0 + a * x + b * y + c * (x * x + y * y);
  }
  double DepthCorrectionFactor(double x, double y) const {
    return DepthCorrectionFactor(depth_correction, x, y);
  }
  // Metres for a raw value, or 0 when the value is invalid or outside [min, max] range.
  double RawToMetres(int raw) const;
  // The 3-D point of a range pixel holding `value_m` (as RawToMetres returned), in the
  // range imager's frame.
  Eigen::Vector3d PixelToPoint(const Eigen::Vector2d& pixel, double value_m) const;
};

// The ray of every pixel of a range imager, computed once: RangeImager::PixelToPoint
// undistorts each pixel by fixed-point iteration, which dominated building a frame's range
// cloud or map points. PixelToPoint here gives the same bits for an integer pixel.
class RangeRays {
 public:
  explicit RangeRays(const RangeImager& range);

  // (x, y) inside the range image.
  Eigen::Vector3d PixelToPoint(int x, int y, double value_m) const {
    return Eigen::Vector3d(rays_[static_cast<size_t>(y) * width_ + x] * value_m);
  }

 private:
  int width_ = 0;
  std::vector<Eigen::Vector3d> rays_;  // row-major; normalised for radial depth
};

// A colour camera and a range imager rigidly mounted together.
struct Rig {
  std::string name;
  PinholeCamera colour;
  RangeImager range;
  // Pose of the range imager in the colour camera's frame: p_colour = T * p_range.
  Eigen::Isometry3d T_colour_range = Eigen::Isometry3d::Identity();
  // Depth registered to colour: same pixel grid, identity extrinsics.
  bool registered = false;
  // Standard deviation of a keypoint's image position, pixels.
  double pixel_sigma = 1.0;
  // Rolling shutter: seconds from the exposure of the colour image's first row to that of its
  // last (negative: read bottom to top); 0 is a global shutter. A frame's timestamp is taken
  // as the time of its middle row. A registered range image is taken as exposed row by row
  // with the colour image (the depth a keypoint lifts through is of its row's time).
  double colour_readout_s = 0.0;

  // The exposure time of a colour pixel row (distorted pixel coordinates, row centres at
  // integers), relative to the frame's timestamp.
  double RowTimeOffset(double row) const {
    return ((row + 0.5) / colour.height - 0.5) * colour_readout_s;
  }

  bool Check(std::string* why) const;
};

}  // namespace ieslam
