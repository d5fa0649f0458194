// Lifting 2-D keypoints to 3-D through the range image (paper §IV, step 3).
//
// Two cameras (the paper's package, 7-Scenes' colour + depth): the keypoint's bearing ray
// from the colour camera is walked through the range image (its epipolar segment between
// the minimum and maximum range); the range pixels near that segment are turned into 3-D
// points in the colour frame through the extrinsics, and the point closest to the ray is
// accepted only if its distance to the ray is within the range imager's precision at that
// depth (noise plus the lateral footprint of one range pixel). The lifted point is the
// cloud point projected onto the ray: bearing from the colour camera, range from the cloud.
// Near depth edges that point may belong to another surface, so the keypoint is refused
// when the cloud points about as near the ray disagree on the range along it, or when the
// range imager does not see the lifted point (a range pixel around its projection that is
// invalid or measures another range).
//
// Registered depth (depth pixel = colour pixel) is the special case handled by a robust
// look-up: the median of a small window, rejected when the window straddles a depth edge.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/option_table.h"

namespace ieslam {

struct LiftingOptions {
  int window_radius = 1;  // range pixels searched on each side of the ray (or the pixel)
  // Distance-to-ray tolerance = sigma_multiplier * sigma_d(d) + footprint_multiplier * (one
  // range pixel's lateral size at d).
  double sigma_multiplier = 3.0;
  double footprint_multiplier = 1.0;
  // Ranges of one surface differ by at most this many sigma_d plus what a slant of 60 deg
  // makes of their lateral distance; more is a depth edge, and the keypoint is refused (the
  // registered look-up's window, the cloud points near the ray).
  double edge_sigma_multiplier = 4.0;
  int min_valid_in_window = 5;  // of (2r+1)^2 for the registered look-up

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<LiftingOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

struct LiftedPoint {
  bool valid = false;
  Eigen::Vector3d p_c = Eigen::Vector3d::Zero();  // in the colour camera's frame
  Eigen::Vector3d z = Eigen::Vector3d::Zero();    // (u, v, d): undistorted pixel and range
  Eigen::Matrix3d Q = Eigen::Matrix3d::Identity();
  // Q carried to p_c through the back-projection (BackProjectedCovariance): what a 3-D/3-D
  // registration weighs the point by.
  Eigen::Matrix3d p_c_covariance = Eigen::Matrix3d::Identity();
};

// The lifted point at p_c (colour camera frame, z > 0): its observation (u, v, d) is p_c's
// undistorted projection and range, Q and p_c_covariance those of the rig's noise model there.
LiftedPoint LiftedPointAt(const Eigen::Vector3d& p_c, const Rig& rig);

class FeatureLifter {
 public:
  // Throws ConfigError for options failing Check() or a rig failing Rig::Check().
  FeatureLifter(const Rig& rig, const LiftingOptions& options);

  // One result per pixel (distorted colour pixel coordinates). `depth` is the range image
  // in metres (CV_32F, 0 = no measurement) as Dataset::Load returns it.
  std::vector<LiftedPoint> Lift(const std::vector<Eigen::Vector2d>& pixels,
                                const cv::Mat& depth) const;

 private:
  // How far apart two ranges near range_m, lateral_m apart, may be on one surface.
  double EdgeAllowance(double range_m, double lateral_m) const;
  // Whether every range pixel of the window around p_c's projection measures p_c's range.
  bool SeenByRangeImager(const Eigen::Vector3d& p_c, const cv::Mat& depth) const;
  LiftedPoint LiftRegistered(const Eigen::Vector2d& pixel, const cv::Mat& depth) const;
  LiftedPoint LiftThroughCloud(const Eigen::Vector2d& pixel, const cv::Mat& depth) const;
  LiftedPoint MakePoint(const Eigen::Vector2d& pixel, const Eigen::Vector3d& ray_unit,
                        double along_ray) const;

  Rig rig_;
  LiftingOptions options_;
  Eigen::Isometry3d T_range_colour_;
};

}  // namespace ieslam
