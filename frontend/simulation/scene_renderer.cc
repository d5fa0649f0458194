#include "frontend/simulation/scene_renderer.h"

#include <functional>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <thread>
#include <vector>

#include <glog/logging.h>

#include "core/dataset.h"
#include "core/error.h"

namespace ieslam {
namespace {

// Runs row(r) for r in [0, rows) on `threads` threads, thread k taking rows k, k + threads, ...
// (interleaved, so that the cheap and expensive parts of an image are shared out evenly).
template <typename RowFunction>
void ForEachRow(int rows, int threads, const RowFunction& row) {
  if (threads <= 1) {
    for (int r = 0; r < rows; ++r) row(r);
    return;
  }
  std::vector<std::thread> workers;
  for (int k = 0; k < threads; ++k) {
    workers.emplace_back([k, rows, threads, &row] {
      for (int r = k; r < rows; r += threads) row(r);
    });
  }
  for (std::thread& worker : workers) worker.join();
}

int ThreadCount(int requested) {
  if (requested > 0) return requested;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

// Everything a pixel's colour needs that does not change from pixel to pixel.
struct ShadingContext {
  const SyntheticScene* scene = nullptr;
  const PinholeCamera* camera = nullptr;
  Eigen::Matrix3d R_w_c;
  Eigen::Vector3d origin_w;
  Eigen::Vector3d light_w;
  double ambient = 0.0;
  double focal = 1.0;  // geometric mean of fx, fy: pixels per unit of normalised coordinate

  // Casts the ray through `pixel`. The ray's camera-frame direction has z = 1, so hit.t is
  // the hit's z coordinate.
  SceneHit Cast(const Eigen::Vector2d& pixel, Eigen::Vector3d* ray_c) const {
    *ray_c = camera->Unproject(pixel);
    return scene->Intersect(origin_w, R_w_c * *ray_c);
  }

  double CosIncidence(const SceneHit& hit, const Eigen::Vector3d& ray_c) const {
    return std::fabs(hit.normal_w.dot(R_w_c * ray_c)) / ray_c.norm();
  }

  // Lit colour of a hit seen by a pixel `pixel_size` pixels wide. The footprint is the
  // pixel's width on a fronto-parallel plane at the hit's depth, stretched by the geometric
  // mean of the two axes of the oblique footprint (1 and 1 / cos incidence).
  Eigen::Vector3f Shade(const SceneHit& hit, double cos_incidence, double pixel_size) const {
    if (!hit.valid()) return Eigen::Vector3f::Zero();
    const double footprint = pixel_size * hit.t / focal / std::sqrt(std::max(cos_incidence, 0.05));
    const double light = ambient + (1.0 - ambient) * std::max(0.0, hit.normal_w.dot(light_w));
    return scene->Albedo(hit, footprint) * static_cast<float>(light);
  }
};

cv::Vec3b ToBgr8(const Eigen::Vector3f& rgb) {
  auto byte = [](float v) {
    return static_cast<uchar>(std::lround(std::min(1.0f, std::max(0.0f, v)) * 255.0f));
  };
  return cv::Vec3b(byte(rgb.z()), byte(rgb.y()), byte(rgb.x()));
}

bool IsEdgePixel(const cv::Mat& surface, int r, int c) {
  const int id = surface.at<int>(r, c);
  return (r > 0 && surface.at<int>(r - 1, c) != id) ||
         (r + 1 < surface.rows && surface.at<int>(r + 1, c) != id) ||
         (c > 0 && surface.at<int>(r, c - 1) != id) ||
         (c + 1 < surface.cols && surface.at<int>(r, c + 1) != id);
}

}  // namespace

bool RenderOptions::Check(std::string* why) const {
  std::ostringstream s;
  if (threads < 0) {
    s << "threads must be >= 0 (0: all cores), got " << threads;
  } else if (edge_supersampling < 1 || edge_supersampling > 8) {
    s << "edge_supersampling must be in [1, 8], got " << edge_supersampling;
  } else if (!light_direction_w.allFinite() || light_direction_w.norm() < 1e-9) {
    s << "light_direction_w must be a finite non-zero vector";
  } else if (!(ambient >= 0.0 && ambient <= 1.0)) {
    s << "ambient must be in [0, 1], got " << ambient;
  } else {
    return true;
  }
  if (why != nullptr) *why = s.str();
  return false;
}

bool RangeSensorModel::Check(std::string* why) const {
  if (max_incidence_deg > 0.0 && max_incidence_deg <= 90.0) return true;
  if (why != nullptr) {
    *why = "max_incidence_deg must be in (0, 90], got " + std::to_string(max_incidence_deg);
  }
  return false;
}

RenderedView RenderView(const SyntheticScene& scene, const PinholeCamera& camera,
                        const Eigen::Isometry3d& T_w_c, const RenderOptions& options) {
  return RenderView(
      scene, camera, [&T_w_c](int) { return T_w_c; }, options);
}

RenderedView RenderView(const SyntheticScene& scene, const PinholeCamera& camera,
                        const std::function<Eigen::Isometry3d(int row)>& T_w_c_of_row,
                        const RenderOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("render options: " + why);
  if (!camera.Check(&why)) throw ConfigError("rendered camera: " + why);
  const int threads = ThreadCount(options.threads);
  ShadingContext frame_context;
  frame_context.scene = &scene;
  frame_context.camera = &camera;
  frame_context.light_w = options.light_direction_w.normalized();
  frame_context.ambient = options.ambient;
  frame_context.focal = std::sqrt(camera.fx * camera.fy);
  // Each row is seen from its own pose (the same one for a global shutter).
  const int rows = camera.height, cols = camera.width;
  std::vector<ShadingContext> row_context(rows, frame_context);
  for (int r = 0; r < rows; ++r) {
    const Eigen::Isometry3d T_w_c = T_w_c_of_row(r);
    row_context[r].R_w_c = T_w_c.linear();
    row_context[r].origin_w = T_w_c.translation();
  }

  RenderedView view;
  view.z_m.create(rows, cols, CV_64FC1);
  view.range_m.create(rows, cols, CV_64FC1);
  view.cos_incidence.create(rows, cols, CV_64FC1);
  view.surface.create(rows, cols, CV_32SC1);
  if (options.colour) view.colour.create(rows, cols, CV_8UC3);

  ForEachRow(rows, threads, [&](int r) {
    const ShadingContext& context = row_context[r];
    for (int c = 0; c < cols; ++c) {
      Eigen::Vector3d ray_c;
      const SceneHit hit = context.Cast(Eigen::Vector2d(c, r), &ray_c);
      const double cos_incidence = hit.valid() ? context.CosIncidence(hit, ray_c) : 0.0;
      view.z_m.at<double>(r, c) = hit.valid() ? hit.t : 0.0;
      view.range_m.at<double>(r, c) = hit.valid() ? hit.t * ray_c.norm() : 0.0;
      view.cos_incidence.at<double>(r, c) = cos_incidence;
      view.surface.at<int>(r, c) = hit.surface;
      if (options.colour)
        view.colour.at<cv::Vec3b>(r, c) = ToBgr8(context.Shade(hit, cos_incidence, 1.0));
    }
  });
  if (!options.colour || options.edge_supersampling == 1) return view;

  // Second pass, once every pixel's surface is known: average n x n sub-pixel rays over
  // the pixels where two surfaces meet.
  const int n = options.edge_supersampling;
  ForEachRow(rows, threads, [&](int r) {
    const ShadingContext& context = row_context[r];
    for (int c = 0; c < cols; ++c) {
      if (!IsEdgePixel(view.surface, r, c)) continue;
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          const Eigen::Vector2d pixel(c - 0.5 + (j + 0.5) / n, r - 0.5 + (i + 0.5) / n);
          Eigen::Vector3d ray_c;
          const SceneHit hit = context.Cast(pixel, &ray_c);
          const double cos_incidence = hit.valid() ? context.CosIncidence(hit, ray_c) : 0.0;
          sum += context.Shade(hit, cos_incidence, 1.0 / n);
        }
      }
      view.colour.at<cv::Vec3b>(r, c) = ToBgr8(sum / static_cast<float>(n * n));
    }
  });
  return view;
}

cv::Mat SimulateRangeImage(const RenderedView& view, const RangeImager& imager,
                           const RangeSensorModel& model, std::mt19937* rng) {
  std::string why;
  if (!model.Check(&why)) throw ConfigError("range sensor model: " + why);
  if (!imager.Check(&why)) throw ConfigError("range imager: " + why);
  CHECK(rng != nullptr);
  CHECK_EQ(view.z_m.rows, imager.camera.height);
  CHECK_EQ(view.z_m.cols, imager.camera.width);
  const double min_cos = std::cos(model.max_incidence_deg * M_PI / 180.0);
  const cv::Mat& value_m = imager.depth_kind == DepthKind::kZ ? view.z_m : view.range_m;
  const cv::Mat factors = DepthCorrectionDivisors(imager);  // empty without a correction
  std::normal_distribution<double> normal(0.0, 1.0);
  cv::Mat raw(value_m.rows, value_m.cols, CV_16UC1);
  for (int r = 0; r < raw.rows; ++r) {
    for (int c = 0; c < raw.cols; ++c) {
      // One draw per pixel whether or not it is valid, so that the noise of a pixel does not
      // depend on the validity of the pixels before it.
      const double e = normal(*rng);
      const double d = value_m.at<double>(r, c) * (factors.empty() ? 1.0 : factors.at<float>(r, c));
      uint16_t out = 0;
      if (view.surface.at<int>(r, c) >= 0 && view.cos_incidence.at<double>(r, c) >= min_cos &&
          d >= imager.min_range_m && d <= imager.max_range_m) {
        const double measured = model.add_noise ? d + imager.noise.Sigma(d) * e : d;
        const long units = std::lround(measured / imager.depth_scale);
        if (units > 0 && units <= 65535) out = static_cast<uint16_t>(units);
      }
      raw.at<uint16_t>(r, c) = out;
    }
  }
  return raw;
}

cv::Mat AddColourNoise(const cv::Mat& colour, double sigma, std::mt19937* rng) {
  CHECK_EQ(colour.type(), CV_8UC3);
  CHECK_GE(sigma, 0.0);
  CHECK(rng != nullptr);
  cv::Mat noisy = colour.clone();
  if (sigma == 0.0) return noisy;
  // float: one engine call per draw instead of two, and plenty for 8-bit levels.
  std::normal_distribution<float> normal(0.0f, static_cast<float>(sigma));
  for (int r = 0; r < noisy.rows; ++r) {
    uchar* p = noisy.ptr<uchar>(r);
    for (int i = 0; i < noisy.cols * 3; ++i) {
      p[i] = cv::saturate_cast<uchar>(p[i] + normal(*rng));  // rounds to nearest
    }
  }
  return noisy;
}

}  // namespace ieslam
