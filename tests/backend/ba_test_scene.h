// A small random scene for the bundle adjustment tests: poses on a short arc looking at a
// cloud of points, and the exact (u, v, d) observations of every point each pose sees.
#pragma once

#include <cmath>
#include <map>
#include <random>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "backend/bundle_adjustment.h"
#include "core/camera.h"
#include "core/observation.h"
#include "core/pose.h"

namespace ieslam {
namespace testing_ba {

inline PinholeCamera TestCamera() {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = 520.0;
  camera.fy = 515.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  return camera;
}

inline Eigen::Matrix3d TestQ() { return Eigen::Vector3d(1.0, 1.0, 0.005 * 0.005).asDiagonal(); }

struct TestScene {
  PinholeCamera camera = TestCamera();
  std::map<int, Vector6d> poses;                                // truth, paper 6-vector
  std::map<int64_t, Eigen::Vector3d> points;                    // truth
  std::map<int, std::vector<FeatureObservation>> observations;  // exact, by frame
};

// `num_poses` poses (frame ids 10, 11, ...) moving sideways and turning a little, all
// looking along +z at `num_points` points 4-9 m away.
inline TestScene MakeTestScene(int num_poses, int num_points, std::mt19937* rng) {
  TestScene scene;
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int k = 0; k < num_poses; ++k) {
    Vector6d pose;
    pose << 0.2 * k, 0.05 * unit(*rng), 0.1 * unit(*rng), 0.05 * unit(*rng), 0.04 * k - 0.1,
        0.05 * unit(*rng);
    scene.poses[10 + k] = pose;
  }
  for (int j = 0; j < num_points; ++j) {
    scene.points[1000 + 7 * j] =
        Eigen::Vector3d(1.0 + 3.0 * unit(*rng), 2.0 * unit(*rng), 6.5 + 2.5 * unit(*rng));
  }
  for (const auto& [frame_id, pose] : scene.poses) {
    for (const auto& [feature_id, p_w] : scene.points) {
      if (WorldToCamera(pose, p_w).z() < 0.5) continue;
      FeatureObservation obs;
      obs.feature_id = feature_id;
      obs.z = PredictObservation(pose, p_w, scene.camera);
      obs.Q = TestQ();
      if (!scene.camera.InImage(obs.z.head<2>())) continue;
      scene.observations[frame_id].push_back(obs);
    }
  }
  return scene;
}

// The scene's observations (optionally with noise drawn from Q) as a problem whose initial
// estimate is the truth perturbed by `sigma_t` metres / `sigma_r` radians per axis (the first
// pose, the anchor, is left exact) and `sigma_p` metres per point coordinate.
inline BundleAdjustmentProblem MakeTestProblem(const TestScene& scene, double sigma_t,
                                               double sigma_r, double sigma_p, bool noisy,
                                               std::mt19937* rng) {
  std::normal_distribution<double> gauss;
  BundleAdjustmentProblem problem;
  for (const auto& [frame_id, pose] : scene.poses) {
    Vector6d start = pose;
    if (frame_id != scene.poses.begin()->first) {
      for (int i = 0; i < 3; ++i) start[i] += sigma_t * gauss(*rng);
      for (int i = 3; i < 6; ++i) start[i] += sigma_r * gauss(*rng);
    }
    problem.T_w_c[frame_id] = PoseToIsometry(start);
  }
  for (const auto& [feature_id, p_w] : scene.points) {
    problem.p_w[feature_id] =
        p_w + sigma_p * Eigen::Vector3d(gauss(*rng), gauss(*rng), gauss(*rng));
  }
  for (const auto& [frame_id, observations] : scene.observations) {
    for (FeatureObservation obs : observations) {
      if (noisy) {
        const Eigen::Matrix3d L = obs.Q.llt().matrixL();
        obs.z += L * Eigen::Vector3d(gauss(*rng), gauss(*rng), gauss(*rng));
      }
      problem.observations.push_back({frame_id, obs});
    }
  }
  return problem;
}

}  // namespace testing_ba
}  // namespace ieslam
