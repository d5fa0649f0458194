// 3-D/3-D registration of matched lifted features (paper §IV, step 4): OpenGV's Arun
// solver inside its RANSAC, with a seeded sampler, then least-squares refits on the inliers
// until the inlier set stops changing. Given each point's covariance, the refits then go on
// weighted by it: Mahalanobis inliers and the covariance-weighted least-squares pose.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/option_table.h"

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
  // With point covariances, correspondence i is an inlier when r^T S^-1 r <= inlier_chi2,
  // r = a_i - T b_i, S = Sigma_a + R Sigma_b R^T (the two points' independent noise). That
  // statistic is chi-square with 3 degrees of freedom for a true match; 16.27 is its 0.999
  // quantile: with a few hundred matches per pair it drops ~0.1% of the true ones (one pair
  // in several loses one), where 0.99 (11.34) would drop several in every pair, while a
  // wrong match a few sigmas off sideways (the isotropic gate's blind spot: along the
  // range, sigma_d is several times the lateral sigma) scores far above it.
  double inlier_chi2 = 16.27;
  // Whether RegisterFrames hands the lifted points' covariances to the registration (off:
  // the isotropic gate and the unweighted fit alone). Off by default: the weighting is only
  // as good as the rig's noise model. Where the model is exact (the synthetic rigs) it
  // helps most the camera + time-of-flight `pair` rig, whose isotropic gate is wide at its
  // range noise and passes wrong matches far off sideways; where the model understates the
  // error of near points (7-Scenes: colour and depth neither registered nor synchronised)
  // the gate trades near points for far ones and the trajectory gets worse (README, "When
  // the noise model is trusted"; the runs in docs/frontend_notes.md).
  bool use_point_covariances = false;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<RegistrationOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

struct RegistrationResult {
  bool success = false;
  std::string reason;                                       // why not, when !success
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();  // p_a = T_a_b * p_b
  std::vector<int> inliers;                                 // indices into the correspondences
  double inlier_ratio = 0.0;
  double rms_m = 0.0;      // residual RMS over the inliers
  double mean_chi2 = 0.0;  // mean r^T S^-1 r over the inliers (with covariances; ~3 if consistent)
  int ransac_iterations = 0;
};

// Registers points_b onto points_a (correspondence i is points_a[i] <-> points_b[i]).
// Deterministic for a given options.seed.
RegistrationResult RegisterPointSets(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const RegistrationOptions& options);

// The same, then with each point's covariance (in its own frame): from the unweighted
// result, inliers by the Mahalanobis test and the pose minimising sum r^T S^-1 r over them
// (S held at the previous rotation in each refit), until the inlier set stops changing.
RegistrationResult RegisterPointSets(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const std::vector<Eigen::Matrix3d>& covariances_a,
                                     const std::vector<Eigen::Matrix3d>& covariances_b,
                                     const RegistrationOptions& options);

}  // namespace ieslam
