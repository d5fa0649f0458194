// CPU ray casting of a SyntheticScene (frontend/simulation/synthetic_scene.h) and the sensor models
// that turn exact geometry into what a colour camera or a range imager would deliver.
//
// RenderView casts one ray through every pixel centre of a PinholeCamera (its distortion
// included: rays come from PinholeCamera::Unproject) and records the exact hit; colour is
// the surface texture, filtered over the pixel's footprint, times a fixed directional light.
// Pixels on a geometric edge (a neighbour sees another surface) are re-rendered with n x n
// sub-pixel rays and averaged, so silhouettes are anti-aliased too.
//
// Threads split the rows; every pixel is a pure function of the scene, camera and pose, so
// the images are identical for any thread count.
//
// The sensor models (noise, invalid pixels, 16-bit quantisation) draw from a std::mt19937
// the caller seeds; they run on one thread, in pixel order.
#pragma once

#include <functional>
#include <random>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "frontend/simulation/synthetic_scene.h"

namespace ieslam {

struct RenderOptions {
  int threads = 1;             // 0: std::thread::hardware_concurrency()
  int edge_supersampling = 3;  // n: n x n rays per edge pixel (1: no anti-aliasing)
  bool colour = true;          // false: geometry only (a range imager)
  Eigen::Vector3d light_direction_w{0.35, 0.55, 0.76};  // towards the light; normalised
  double ambient = 0.55;                                // light on faces turned away from the light

  bool Check(std::string* why) const;
};

// Exact per-pixel geometry and the noise-free colour of one view.
struct RenderedView {
  cv::Mat colour;         // CV_8UC3 BGR; empty when RenderOptions::colour is false
  cv::Mat z_m;            // CV_64FC1 z of the hit (camera frame) at each pixel centre
  cv::Mat range_m;        // CV_64FC1 distance from the optical centre to that hit
  cv::Mat cos_incidence;  // CV_64FC1 |cos| of the angle between the ray and the normal
  cv::Mat surface;        // CV_32SC1 surface index hit at the pixel centre (-1: none)
};

// Renders the view of `camera` at pose T_w_c. Throws ConfigError for options or a camera
// failing their Check().
RenderedView RenderView(const SyntheticScene& scene, const PinholeCamera& camera,
                        const Eigen::Isometry3d& T_w_c, const RenderOptions& options);

// The same with each pixel row seen from its own pose (a rolling shutter): T_w_c_of_row(r) is
// called once per row, on the caller's thread.
RenderedView RenderView(const SyntheticScene& scene, const PinholeCamera& camera,
                        const std::function<Eigen::Isometry3d(int row)>& T_w_c_of_row,
                        const RenderOptions& options);

// How a range imager turns exact geometry into raw 16-bit values.
struct RangeSensorModel {
  // Pixels whose ray meets the surface more obliquely than this read 0 (no return).
  double max_incidence_deg = 75.0;
  bool add_noise = true;  // Gaussian range noise with the imager's sigma(d)

  bool Check(std::string* why) const;
};

// The raw range image (CV_16UC1) of `view` as `imager` reports it: z or radial distance per
// imager.depth_kind, times the imager's depth correction factor at the pixel (its systematic
// error, RangeImager::depth_correction), plus noise N(0, imager.noise.Sigma(d)^2) (when
// enabled), rounded to imager.depth_scale; 0 (no measurement) for grazing pixels, for no hit,
// and outside [min_range_m, max_range_m] (judged on the noise-free value, as a sensor's
// hardware gate would be) or past the 16-bit range. Throws ConfigError for a model or an imager
// failing their Check().
cv::Mat SimulateRangeImage(const RenderedView& view, const RangeImager& imager,
                           const RangeSensorModel& model, std::mt19937* rng);

// Adds N(0, sigma^2) grey levels of noise to each channel of an 8-bit colour image, rounded
// and saturated. sigma = 0 returns a copy.
cv::Mat AddColourNoise(const cv::Mat& colour, double sigma, std::mt19937* rng);

}  // namespace ieslam
