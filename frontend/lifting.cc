#include "frontend/lifting.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <glog/logging.h>

#include "core/error.h"
#include "core/observation.h"

namespace ieslam {

const OptionTable<LiftingOptions>& LiftingOptions::Table() {
  static const OptionTable<LiftingOptions>* table = [] {
    using O = LiftingOptions;
    auto* t = new OptionTable<O>;
    t->Int("window_radius", &O::window_radius,
           "range pixels searched around the ray (or the pixel)")
        .Range(0, 5);
    t->Double("sigma_multiplier", &O::sigma_multiplier,
              "distance-to-ray tolerance: k sigma_d(d) + one range pixel")
        .Above(0.0);
    t->Double("footprint_multiplier", &O::footprint_multiplier,
              "range pixels' lateral size in the tolerance")
        .Min(0.0);
    t->Double("edge_sigma_multiplier", &O::edge_sigma_multiplier,
              "range sigmas within which one surface's ranges lie")
        .Above(0.0);
    t->Int("min_valid_in_window", &O::min_valid_in_window,
           "valid range pixels the registered look-up needs")
        .Min(1);
    t->Require([](const O& o) {
      const int window = (2 * o.window_radius + 1) * (2 * o.window_radius + 1);
      return o.min_valid_in_window <= window
                 ? std::string()
                 : "min_valid_in_window must be <= (2 window_radius + 1)^2 = " +
                       std::to_string(window) + ", got " + std::to_string(o.min_valid_in_window);
    });
    return t;
  }();
  return *table;
}

LiftedPoint LiftedPointAt(const Eigen::Vector3d& p_c, const Rig& rig) {
  CHECK_GT(p_c.z(), 0.0);
  LiftedPoint point;
  point.valid = true;
  point.p_c = p_c;
  const double range = p_c.norm();
  point.z = Eigen::Vector3d(rig.colour.fx * p_c.x() / p_c.z() + rig.colour.cx,
                            rig.colour.fy * p_c.y() / p_c.z() + rig.colour.cy, range);
  point.Q = ObservationCovariance(rig.pixel_sigma, rig.range.noise, range);
  point.p_c_covariance = BackProjectedCovariance(p_c, point.Q, rig.colour);
  return point;
}

FeatureLifter::FeatureLifter(const Rig& rig, const LiftingOptions& options)
    : rig_(rig), options_(options), T_range_colour_(rig.T_colour_range.inverse()) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  if (!rig.Check(&why)) throw ConfigError("rig '" + rig.name + "': " + why);
}

std::vector<LiftedPoint> FeatureLifter::Lift(const std::vector<Eigen::Vector2d>& pixels,
                                             const cv::Mat& depth) const {
  CHECK_EQ(depth.type(), CV_32F);
  CHECK_EQ(depth.cols, rig_.range.camera.width);
  CHECK_EQ(depth.rows, rig_.range.camera.height);
  std::vector<LiftedPoint> lifted;
  lifted.reserve(pixels.size());
  for (const Eigen::Vector2d& pixel : pixels) {
    lifted.push_back(rig_.registered ? LiftRegistered(pixel, depth)
                                     : LiftThroughCloud(pixel, depth));
  }
  return lifted;
}

LiftedPoint FeatureLifter::MakePoint(const Eigen::Vector2d& pixel, const Eigen::Vector3d& ray_unit,
                                     double along_ray) const {
  LiftedPoint point;
  point.valid = true;
  point.p_c = ray_unit * along_ray;
  const Eigen::Vector3d n = rig_.colour.Unproject(pixel);  // undistorted, z = 1
  point.z = Eigen::Vector3d(rig_.colour.fx * n.x() + rig_.colour.cx,
                            rig_.colour.fy * n.y() + rig_.colour.cy, along_ray);
  point.Q = ObservationCovariance(rig_.pixel_sigma, rig_.range.noise, along_ray);
  point.p_c_covariance = BackProjectedCovariance(point.p_c, point.Q, rig_.colour);
  return point;
}

double FeatureLifter::EdgeAllowance(double range_m, double lateral_m) const {
  // A surface slanted at up to ~60 deg changes range by lateral * tan(60) over a lateral
  // extent; more than that plus the noise is a depth edge.
  return options_.edge_sigma_multiplier * rig_.range.noise.Sigma(range_m) +
         lateral_m * std::tan(60.0 * M_PI / 180.0);
}

LiftedPoint FeatureLifter::LiftRegistered(const Eigen::Vector2d& pixel,
                                          const cv::Mat& depth) const {
  const int x0 = static_cast<int>(std::lround(pixel.x()));
  const int y0 = static_cast<int>(std::lround(pixel.y()));
  const int r = options_.window_radius;
  if (x0 - r < 0 || y0 - r < 0 || x0 + r >= depth.cols || y0 + r >= depth.rows) return {};
  float values[121];
  int n = 0;
  for (int y = y0 - r; y <= y0 + r; ++y) {
    for (int x = x0 - r; x <= x0 + r; ++x) {
      const float v = depth.at<float>(y, x);
      if (v > 0.0f && std::isfinite(v)) values[n++] = v;
    }
  }
  if (n < options_.min_valid_in_window) return {};
  std::sort(values, values + n);
  const double median = values[n / 2];
  // The window spans 2r pixels.
  if (values[n - 1] - values[0] > EdgeAllowance(median, 2.0 * r * median / rig_.range.camera.fx)) {
    return {};
  }
  const Eigen::Vector3d ray = rig_.colour.Unproject(pixel);
  const Eigen::Vector3d p = rig_.range.depth_kind == DepthKind::kZ ? Eigen::Vector3d(ray * median)
                                                                   : ray.normalized() * median;
  return MakePoint(pixel, ray.normalized(), p.norm());
}

bool FeatureLifter::SeenByRangeImager(const Eigen::Vector3d& p_c, const cv::Mat& depth) const {
  const Eigen::Vector3d p_r = T_range_colour_ * p_c;
  if (p_r.z() <= 0.0) return false;
  const Eigen::Vector2d q = rig_.range.camera.Project(p_r);
  const int x0 = static_cast<int>(std::lround(q.x())), y0 = static_cast<int>(std::lround(q.y()));
  const int r = options_.window_radius;
  if (x0 - r < 0 || y0 - r < 0 || x0 + r >= depth.cols || y0 + r >= depth.rows) return false;
  const double value = rig_.range.depth_kind == DepthKind::kZ ? p_r.z() : p_r.norm();
  // Window pixels are up to r + 1 pixels (diagonally) from the point's projection.
  const double allowed =
      EdgeAllowance(value, (r + 1) * std::sqrt(2.0) * value / rig_.range.camera.fx);
  for (int y = y0 - r; y <= y0 + r; ++y) {
    for (int x = x0 - r; x <= x0 + r; ++x) {
      const float v = depth.at<float>(y, x);
      if (!(v > 0.0f) || !std::isfinite(v) || std::abs(v - value) > allowed) return false;
    }
  }
  return true;
}

LiftedPoint FeatureLifter::LiftThroughCloud(const Eigen::Vector2d& pixel,
                                            const cv::Mat& depth) const {
  const PinholeCamera& range_camera = rig_.range.camera;
  const Eigen::Vector3d ray_c = rig_.colour.Unproject(pixel).normalized();
  const Eigen::Vector3d origin_r = T_range_colour_.translation();
  const Eigen::Vector3d ray_r = T_range_colour_.linear() * ray_c;

  // The ray's epipolar segment in the range image, between min and max range.
  const double s_near = rig_.range.min_range_m, s_far = rig_.range.max_range_m;
  const Eigen::Vector3d near_r = origin_r + s_near * ray_r, far_r = origin_r + s_far * ray_r;
  if (near_r.z() <= 0.0 || far_r.z() <= 0.0) return {};
  const Eigen::Vector2d a = range_camera.Project(near_r), b = range_camera.Project(far_r);
  const int steps = std::min(4000, static_cast<int>(std::ceil((b - a).norm() * 2.0)) + 1);

  const int r = options_.window_radius;
  double best_distance = std::numeric_limits<double>::max(), best_along = 0.0;
  int last_x = std::numeric_limits<int>::min(), last_y = last_x;
  std::vector<std::pair<double, double>> visited;  // (distance to the ray, position along it)
  for (int i = 0; i < steps; ++i) {
    const Eigen::Vector2d p =
        steps == 1 ? a : Eigen::Vector2d(a + (b - a) * (double(i) / (steps - 1)));
    const int cx = static_cast<int>(std::lround(p.x())), cy = static_cast<int>(std::lround(p.y()));
    if (cx == last_x && cy == last_y) continue;
    last_x = cx;
    last_y = cy;
    for (int y = std::max(0, cy - r); y <= std::min(depth.rows - 1, cy + r); ++y) {
      for (int x = std::max(0, cx - r); x <= std::min(depth.cols - 1, cx + r); ++x) {
        const float v = depth.at<float>(y, x);
        if (!(v > 0.0f) || !std::isfinite(v)) continue;
        const Eigen::Vector3d q_c = rig_.T_colour_range * rig_.range.PixelToPoint({x, y}, v);
        const double along = q_c.dot(ray_c);
        if (along <= 0.0) continue;
        const double distance = (q_c - along * ray_c).norm();
        visited.emplace_back(distance, along);
        if (distance < best_distance) {
          best_distance = distance;
          best_along = along;
        }
      }
    }
  }
  if (best_along <= 0.0) return {};
  const double footprint = best_along / range_camera.fx;
  const double tolerance = options_.sigma_multiplier * rig_.range.noise.Sigma(best_along) +
                           options_.footprint_multiplier * footprint;
  if (best_distance > tolerance) return {};
  // Near a depth edge that tolerance (mostly range noise, several range pixels wide) lets
  // points of the wrong surface through: the nearest point may lie across a silhouette, or
  // be the background seen past a surface that gave the imager no return (too oblique) or
  // that its viewpoint does not see. Refuse unless (1) the points about as near the ray as
  // the nearest (within one footprint more) agree on the position along it, and (2) the
  // imager sees the lifted point: every pixel around its projection holds a range that
  // agrees with it.
  const double near_enough = best_distance + footprint;
  double lo = best_along, hi = best_along;
  for (const auto& [distance, along] : visited) {
    if (distance > near_enough) continue;
    lo = std::min(lo, along);
    hi = std::max(hi, along);
  }
  if (hi - lo > EdgeAllowance(best_along, 2.0 * near_enough)) return {};
  if (!SeenByRangeImager(best_along * ray_c, depth)) return {};
  return MakePoint(pixel, ray_c, best_along);
}

}  // namespace ieslam
