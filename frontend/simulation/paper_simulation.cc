#include "frontend/simulation/paper_simulation.h"

#include <cmath>
#include <random>
#include <sstream>

#include "core/error.h"

namespace ieslam {
namespace {

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

bool InUnitInterval(double v) { return v >= 0.0 && v <= 1.0; }

// Uniform features in the box; ids are indices.
std::vector<Eigen::Vector3d> DrawFeatures(const SimulationOptions& o, std::mt19937* scene_rng) {
  std::uniform_real_distribution<double> unit(-0.5, 0.5);
  std::vector<Eigen::Vector3d> features;
  features.reserve(o.feature_count);
  for (int i = 0; i < o.feature_count; ++i) {
    const double x = unit(*scene_rng);
    const double y = unit(*scene_rng);
    const double z = unit(*scene_rng);
    features.push_back(o.volume_centre_m + Eigen::Vector3d(x, y, z).cwiseProduct(o.volume_size_m));
  }
  return features;
}

// Thins the features that any pose of the stretch sees to keep_fraction of them and
// renumbers the survivors 0..M-1 (in their original order).
std::vector<Eigen::Vector3d> ThinFeaturePoorRegion(const SimulationOptions& o,
                                                   const std::vector<Vector6d>& T_w_c,
                                                   const std::vector<bool>& in_stretch,
                                                   std::vector<Eigen::Vector3d> features,
                                                   std::mt19937* scene_rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Eigen::Vector3d> kept;
  kept.reserve(features.size());
  for (const Eigen::Vector3d& p_w : features) {
    bool in_region = false;
    for (size_t k = 0; k < T_w_c.size() && !in_region; ++k) {
      in_region = in_stretch[k] && IsFeatureVisible(T_w_c[k], p_w, o.camera, 0.0, o.max_range_m);
    }
    if (!in_region || unit(*scene_rng) < o.feature_poor_keep_fraction) kept.push_back(p_w);
  }
  return kept;
}

}  // namespace

PinholeCamera PaperSimulationCamera() {
  PinholeCamera camera;
  camera.width = 1024;
  camera.height = 768;
  camera.fx = 800.0;
  camera.fy = 800.0;
  camera.cx = 511.5;
  camera.cy = 383.5;
  return camera;
}

bool SimulationOptions::Check(std::string* why) const {
  std::string sub_why;
  if (!trajectory.Check(&sub_why)) return Fail(why, "trajectory: " + sub_why);
  std::ostringstream s;
  if (feature_count < 1) {
    s << "feature_count must be at least 1, got " << feature_count;
    return Fail(why, s.str());
  }
  if (!volume_size_m.allFinite() || !(volume_size_m.minCoeff() > 0.0)) {
    s << "volume_size_m must be positive and finite, got " << volume_size_m.transpose();
    return Fail(why, s.str());
  }
  if (!volume_centre_m.allFinite()) return Fail(why, "volume_centre_m must be finite");
  if (!camera.Check(&sub_why)) return Fail(why, "camera: " + sub_why);
  // The observation model (core/observation.h) works on undistorted pixels.
  if (camera.HasDistortion()) return Fail(why, "camera: the simulation has no lens distortion");
  if (!(min_range_m >= 0.0) || !(max_range_m > min_range_m) || !std::isfinite(max_range_m)) {
    s << "ranges must satisfy 0 <= min_range_m < max_range_m < inf, got " << min_range_m << " and "
      << max_range_m;
    return Fail(why, s.str());
  }
  if (!(pixel_sigma > 0.0) || !std::isfinite(pixel_sigma)) {
    s << "pixel_sigma must be positive and finite, got " << pixel_sigma;
    return Fail(why, s.str());
  }
  // Q must be invertible at every range in [min, max]: sigma_d positive and non-decreasing.
  if (!(range_noise.a >= 0.0 && range_noise.b >= 0.0 && range_noise.c >= 0.0) ||
      !std::isfinite(range_noise.Sigma(max_range_m)) || !(range_noise.Sigma(min_range_m) > 0.0)) {
    s << "range_noise needs a, b, c >= 0 and sigma_d(min_range_m) > 0, got a=" << range_noise.a
      << " b=" << range_noise.b << " c=" << range_noise.c;
    return Fail(why, s.str());
  }
  if (!InUnitInterval(outlier_fraction)) {
    s << "outlier_fraction must be in [0, 1], got " << outlier_fraction;
    return Fail(why, s.str());
  }
  if (!InUnitInterval(feature_poor_start) || !InUnitInterval(feature_poor_length) ||
      !(feature_poor_start + feature_poor_length <= 1.0) ||
      !InUnitInterval(feature_poor_keep_fraction)) {
    s << "feature-poor stretch needs start, length, keep_fraction in [0, 1] and start + length "
         "<= 1, got start="
      << feature_poor_start << " length=" << feature_poor_length
      << " keep_fraction=" << feature_poor_keep_fraction;
    return Fail(why, s.str());
  }
  return true;
}

bool IsFeatureVisible(const Vector6d& T_w_c, const Eigen::Vector3d& p_w,
                      const PinholeCamera& camera, double min_range_m, double max_range_m) {
  const Eigen::Vector3d p_c = WorldToCamera(T_w_c, p_w);
  if (!(p_c.z() > 0.0)) return false;
  const double range = p_c.norm();
  if (range < min_range_m || range > max_range_m) return false;
  const Eigen::Vector2d pixel(camera.fx * p_c.x() / p_c.z() + camera.cx,
                              camera.fy * p_c.y() / p_c.z() + camera.cy);
  return camera.InImage(pixel);
}

SimulatedDataset SimulatePaperScenario(const SimulationOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw ConfigError("simulation options: " + why);

  SimulatedDataset data;
  data.options = o;
  data.camera = o.camera;
  data.pixel_sigma = o.pixel_sigma;
  data.range_noise = o.range_noise;

  // The scene: trajectory (no randomness), then features from scene_seed only.
  const PaperTrajectory trajectory = BuildPaperTrajectory(o.trajectory);
  data.T_w_c_true = trajectory.T_w_c;
  data.corner_poses = trajectory.corner_poses;
  data.path_vertices = trajectory.vertices;
  const int n = data.num_poses();
  data.in_feature_poor_stretch.assign(n, false);
  bool any_poor = false;
  for (int k = 0; k < n; ++k) {
    // Poses are equally spaced in arc length, so this is the position within its loop.
    const double loops_done = static_cast<double>(k) * o.trajectory.num_loops / n;
    const double within_loop = loops_done - std::floor(loops_done);
    data.in_feature_poor_stretch[k] = within_loop >= o.feature_poor_start &&
                                      within_loop < o.feature_poor_start + o.feature_poor_length;
    any_poor = any_poor || data.in_feature_poor_stretch[k];
  }

  std::mt19937 scene_rng(o.scene_seed);
  data.features_true = DrawFeatures(o, &scene_rng);
  if (any_poor) {
    data.features_true = ThinFeaturePoorRegion(o, data.T_w_c_true, data.in_feature_poor_stretch,
                                               std::move(data.features_true), &scene_rng);
  }

  // The measurements: noise and outliers from noise_seed only, on separate engines so that
  // switching outliers on does not change the noise of the observations that stay inliers.
  std::mt19937 noise_rng(o.noise_seed);
  std::seed_seq outlier_seed{o.noise_seed, 0x6f75746cu};
  std::mt19937 outlier_rng(outlier_seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);

  data.observations.resize(n);
  data.truth.resize(n);
  for (int k = 0; k < n; ++k) {
    const Vector6d& T_w_c = data.T_w_c_true[k];
    for (size_t id = 0; id < data.features_true.size(); ++id) {
      const Eigen::Vector3d& p_w = data.features_true[id];
      if (!IsFeatureVisible(T_w_c, p_w, o.camera, o.min_range_m, o.max_range_m)) continue;
      SimulatedObservationTruth truth;
      truth.z_true = PredictObservation(T_w_c, p_w, o.camera);
      FeatureObservation obs;
      obs.feature_id = static_cast<int64_t>(id);
      obs.z = truth.z_true;
      if (o.add_noise) {
        const double sigma_d = o.range_noise.Sigma(truth.z_true.z());
        obs.z.x() += o.pixel_sigma * normal(noise_rng);
        obs.z.y() += o.pixel_sigma * normal(noise_rng);
        obs.z.z() += sigma_d * normal(noise_rng);
      }
      // The covariance the noise was drawn from: at the true range, not the measured one.
      double q_range = truth.z_true.z();
      truth.outlier = unit(outlier_rng) < o.outlier_fraction;
      if (truth.outlier) {
        obs.z.x() = -0.5 + o.camera.width * unit(outlier_rng);
        obs.z.y() = -0.5 + o.camera.height * unit(outlier_rng);
        obs.z.z() = o.min_range_m + (o.max_range_m - o.min_range_m) * unit(outlier_rng);
        q_range = obs.z.z();  // all a front end could know
      }
      obs.Q = ObservationCovariance(o.pixel_sigma, o.range_noise, q_range);
      data.observations[k].push_back(obs);
      data.truth[k].push_back(truth);
    }
  }
  return data;
}

Rig PaperSimulationRig(const SimulationOptions& o) {
  Rig rig;
  rig.name = "paper-simulation";
  rig.colour = o.camera;
  rig.range.camera = o.camera;
  rig.range.depth_kind = DepthKind::kRadial;
  rig.range.min_range_m = o.min_range_m;
  rig.range.max_range_m = o.max_range_m;
  rig.range.noise = o.range_noise;
  rig.registered = true;
  rig.pixel_sigma = o.pixel_sigma;
  return rig;
}

std::vector<int> VisibleFeatureCounts(const SimulatedDataset& dataset) {
  std::vector<int> counts;
  counts.reserve(dataset.observations.size());
  for (const auto& pose_observations : dataset.observations) {
    counts.push_back(static_cast<int>(pose_observations.size()));
  }
  return counts;
}

}  // namespace ieslam
