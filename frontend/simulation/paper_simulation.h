// The feature-level simulation of Zhou et al. (2008), §VI-A: a camera + range imager flown
// twice round a piecewise polygonal 3-D path (frontend/simulation/simulation_trajectory.h) through
// 2000 random point features in a 20 m x 20 m x 6 m volume (6 m vertical), observing
// z = (u, v, d) of every feature in view with known data association.
//
// What it promises:
//  - The same options (both seeds included) give the same dataset bit for bit; the scene
//    (trajectory and features) depends only on scene_seed, the noise and outliers only on
//    noise_seed, so a Monte-Carlo run varies noise_seed over one fixed scene.
//  - Every observation's Q is the covariance its noise was drawn from: the pixel sigma on
//    u and v, the range noise model at the true range on d. Outliers are not drawn from Q;
//    they are flagged in `truth` so that tests can count them.
//  - The sensor is registered (range along each colour pixel's ray, identity extrinsics),
//    without lens distortion: the observation model of core/observation.h exactly.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/observation.h"
#include "core/pose.h"
#include "frontend/simulation/simulation_trajectory.h"

namespace ieslam {

// The paper's 1024x768 camera with fx = fy = 800 px: 65 deg horizontal, 51 deg vertical
// field of view; no distortion.
PinholeCamera PaperSimulationCamera();

struct SimulationOptions {
  PaperTrajectoryOptions trajectory;

  int feature_count = 2000;
  // Axis-aligned box the features fill uniformly: x, y horizontal, z vertical (the paper's
  // 20 m x 6 m x 20 m with its 6 m as the height), centred on volume_centre_m.
  Eigen::Vector3d volume_size_m{20.0, 20.0, 6.0};
  Eigen::Vector3d volume_centre_m = Eigen::Vector3d::Zero();

  PinholeCamera camera = PaperSimulationCamera();
  double min_range_m = 0.3;
  double max_range_m = 7.5;  // the SwissRanger SR-3000's non-ambiguity range
  double pixel_sigma = 1.0;  // sigma_u = sigma_v, pixels
  // sigma_d(d) = 5 mm + 1% of the range: a time-of-flight imager's roughly linear growth.
  RangeNoiseModel range_noise{0.005, 0.01, 0.0};
  // When false the observations are the exact predictions, but Q is still the covariance
  // above: noise-free data for checking that an estimator recovers the truth.
  bool add_noise = true;
  // Probability that an observation is replaced by a uniform random (u, v, d) in the image
  // and [min_range_m, max_range_m].
  double outlier_fraction = 0.0;

  // A feature-poor stretch: the poses in [start, start + length) of every loop (fractions
  // of one loop's length) see a region where only keep_fraction of the features survive.
  // The region is the union of those poses' view frusta out to max_range_m, so every loop
  // meets it at the same place. Length 0 disables it.
  double feature_poor_start = 0.25;
  double feature_poor_length = 0.0;
  double feature_poor_keep_fraction = 0.2;

  uint32_t scene_seed = 1;
  uint32_t noise_seed = 2;

  bool Check(std::string* why) const;
};

// Ground truth about one observation, parallel to SimulatedDataset::observations.
struct SimulatedObservationTruth {
  Eigen::Vector3d z_true = Eigen::Vector3d::Zero();  // the noise-free prediction
  bool outlier = false;
};

struct SimulatedDataset {
  SimulationOptions options;                   // as used
  std::vector<Vector6d> T_w_c_true;            // one per pose
  std::vector<Eigen::Vector3d> features_true;  // p_w of feature id i at index i
  // Per pose, the observations of every feature in view, in increasing feature id.
  std::vector<std::vector<FeatureObservation>> observations;
  std::vector<std::vector<SimulatedObservationTruth>> truth;  // parallel to observations
  PinholeCamera camera;
  double pixel_sigma = 1.0;
  RangeNoiseModel range_noise;
  // The first pose past each corner of the path, and the poses of the feature-poor stretch.
  std::vector<int> corner_poses;
  std::vector<bool> in_feature_poor_stretch;
  std::vector<Eigen::Vector3d> path_vertices;

  int num_poses() const { return static_cast<int>(T_w_c_true.size()); }
};

// True when p_w is in front of the camera, projects inside the image and lies at a range
// in [min_range_m, max_range_m].
bool IsFeatureVisible(const Vector6d& T_w_c, const Eigen::Vector3d& p_w,
                      const PinholeCamera& camera, double min_range_m, double max_range_m);

// Throws ConfigError (with Check()'s reason) for bad options.
SimulatedDataset SimulatePaperScenario(const SimulationOptions& options);

// A registered rig (colour = range camera, identity extrinsics) carrying the simulation's
// intrinsics, ranges and noise, for code that wants a Rig.
Rig PaperSimulationRig(const SimulationOptions& options);

// Number of features observed from each pose (outliers included: they replace in-view
// observations).
std::vector<int> VisibleFeatureCounts(const SimulatedDataset& dataset);

}  // namespace ieslam
