#include "core/camera.h"

#include <cmath>
#include <sstream>

namespace ieslam {
namespace {

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

bool Finite(const PinholeCamera& c) {
  bool finite =
      std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy);
  for (double d : c.distortion) finite = finite && std::isfinite(d);
  return finite;
}

}  // namespace

bool PinholeCamera::Check(std::string* why) const {
  std::ostringstream s;
  if (width <= 0 || height <= 0) {
    s << "image size must be positive, got " << width << "x" << height;
    return Fail(why, s.str());
  }
  if (!Finite(*this)) return Fail(why, "intrinsics or distortion contain NaN or inf");
  if (fx <= 0.0 || fy <= 0.0) {
    s << "focal lengths must be positive, got fx=" << fx << " fy=" << fy;
    return Fail(why, s.str());
  }
  return true;
}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d K;
  K << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return K;
}

Eigen::Vector2d PinholeCamera::Undistort(const Eigen::Vector2d& distorted) const {
  if (!HasDistortion()) return distorted;
  Eigen::Vector2d n = distorted;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector2d step = distorted - Distort(n);
    n += step;
    if (step.squaredNorm() < 1e-28) break;
  }
  return n;
}

Eigen::Vector3d PinholeCamera::Unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d n =
      Undistort(Eigen::Vector2d((pixel.x() - cx) / fx, (pixel.y() - cy) / fy));
  return {n.x(), n.y(), 1.0};
}

bool PinholeCamera::InImage(const Eigen::Vector2d& pixel, double border) const {
  return pixel.x() >= -0.5 + border && pixel.y() >= -0.5 + border &&
         pixel.x() < width - 0.5 - border && pixel.y() < height - 0.5 - border;
}

bool RangeImager::Check(std::string* why) const {
  std::string camera_why;
  if (!camera.Check(&camera_why)) return Fail(why, "range imager: " + camera_why);
  if (!(depth_scale > 0.0) || !std::isfinite(depth_scale)) {
    return Fail(why, "range imager: depth_scale must be positive and finite, got " +
                         std::to_string(depth_scale));
  }
  if (!(min_range_m >= 0.0) || !(max_range_m > min_range_m) || !std::isfinite(max_range_m)) {
    return Fail(why, "range imager: need 0 <= min_range < max_range, got " +
                         std::to_string(min_range_m) + ", " + std::to_string(max_range_m));
  }
  if (!std::isfinite(noise.a) || !std::isfinite(noise.b) || !std::isfinite(noise.c) ||
      noise.a < 0.0 || noise.b < 0.0 || noise.c < 0.0 || noise.Sigma(max_range_m) <= 0.0) {
    return Fail(why, "range imager: noise coefficients must be finite, non-negative and not all 0");
  }
  if (HasDepthCorrection()) {
    for (const double k : depth_correction) {
      // Half a reading per unit of normalised coordinate is no calibration any more.
      if (!(std::fabs(k) <= kMaxDepthCorrectionCoefficient)) {
        return Fail(why, "range imager: depth_correction coefficients must be within +-0.5, got " +
                             std::to_string(k));
      }
    }
    // The factor on a grid over the image (a quadratic's extremes lie on its border or at
    // one interior point, which a 17 x 17 grid comes close to): a correction that halves or
    // doubles a reading is no calibration.
    for (int i = 0; i <= 16; ++i) {
      for (int j = 0; j <= 16; ++j) {
        const Eigen::Vector2d pixel(i * (camera.width - 1) / 16.0, j * (camera.height - 1) / 16.0);
        const Eigen::Vector3d ray = camera.Unproject(pixel);
        const double factor = DepthCorrectionFactor(ray.x(), ray.y());
        if (!(factor >= kMinDepthCorrectionFactor && factor <= kMaxDepthCorrectionFactor)) {
          std::ostringstream message;
          message << "range imager: depth_correction gives a factor of " << factor << " at pixel ("
                  << pixel.x() << ", " << pixel.y() << "); it must stay within [0.5, 2]";
          return Fail(why, message.str());
        }
      }
    }
  }
  return true;
}

double RangeImager::RawToMetres(int raw) const {
  for (int invalid : invalid_values) {
    if (raw == invalid) return 0.0;
  }
  const double metres = raw * depth_scale;
  return (metres >= min_range_m && metres <= max_range_m) ? metres : 0.0;
}

Eigen::Vector3d RangeImager::PixelToPoint(const Eigen::Vector2d& pixel, double value_m) const {
  const Eigen::Vector3d ray = camera.Unproject(pixel);
  return depth_kind == DepthKind::kZ ? Eigen::Vector3d(ray * value_m)
                                     : Eigen::Vector3d(ray.normalized() * value_m);
}

RangeRays::RangeRays(const RangeImager& range) : width_(range.camera.width) {
  rays_.reserve(static_cast<size_t>(range.camera.width) * range.camera.height);
  for (int y = 0; y < range.camera.height; ++y) {
    for (int x = 0; x < range.camera.width; ++x) {
      const Eigen::Vector3d ray = range.camera.Unproject(Eigen::Vector2d(x, y));
      rays_.push_back(range.depth_kind == DepthKind::kZ ? ray : Eigen::Vector3d(ray.normalized()));
    }
  }
}

bool Rig::Check(std::string* why) const {
  std::string part;
  if (!colour.Check(&part)) return Fail(why, "colour camera: " + part);
  if (!range.Check(&part)) return Fail(why, part);
  if (!T_colour_range.matrix().allFinite()) return Fail(why, "extrinsics contain NaN or inf");
  const Eigen::Matrix3d R = T_colour_range.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0.0) {
    return Fail(why, "extrinsic rotation is not a rotation matrix");
  }
  if (!(pixel_sigma > 0.0) || !std::isfinite(pixel_sigma)) {
    return Fail(why, "pixel_sigma must be positive, got " + std::to_string(pixel_sigma));
  }
  // A rolling shutter reads its rows within one frame period; 0.2 s is a 5 Hz camera's.
  if (!(std::fabs(colour_readout_s) <= 0.2)) {
    return Fail(
        why, "colour readout time must be within +-0.2 s, got " + std::to_string(colour_readout_s));
  }
  if (registered && (colour.width != range.camera.width || colour.height != range.camera.height)) {
    return Fail(why, "registered rig needs equal colour and range resolutions");
  }
  return true;
}

}  // namespace ieslam
