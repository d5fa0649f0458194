// 3-D/3-D registration of matched lifted features (paper §IV, step 4): OpenGV's Arun
// solver inside its RANSAC, with a seeded sampler, then least-squares refits on the inliers
// until the inlier set stops changing.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ieslam {

struct RegistrationOptions {
  // Inlier distance between a point and its transformed match. Kinect-class range noise is
  // sigma ~ 1 cm at 2.5 m, so two points differ by ~1.4 sigma_d: 3 cm keeps ~3 sigma up to
  // about 2.5 m and stays well below the spacing of distinct features.
  double inlier_threshold_m = 0.03;
  // RegisterFrames raises the threshold to this many sigmas of the difference of two matched
  // points' range noise (median over the matches): a time-of-flight imager at 2 m has
  // sigma_d ~ 2.5 cm, where 3 cm would reject most true matches.
  double inlier_noise_sigmas = 3.0;
  int max_iterations = 500;
  double probability = 0.999;
  int min_inliers = 10;
  // Refuse when the inliers do not span a volume: the square root of the second-largest
  // eigenvalue of their scatter (metres) must exceed this (collinear or tiny-patch sets).
  double min_spread_m = 0.03;
  int max_refinements = 10;
  uint32_t seed = 42;

  bool Check(std::string* why) const;
};

struct RegistrationResult {
  bool success = false;
  std::string reason;                                  // why not, when !success
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();  // p_a = T_a_b * p_b
  std::vector<int> inliers;                            // indices into the correspondences
  double inlier_ratio = 0.0;
  double rms_m = 0.0;                                  // residual RMS over the inliers
  int ransac_iterations = 0;
};

// Registers points_b onto points_a (correspondence i is points_a[i] <-> points_b[i]).
// Deterministic for a given options.seed.
RegistrationResult RegisterPointSets(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const RegistrationOptions& options);

}  // namespace ieslam
