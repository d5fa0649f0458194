// A small scene for the filter's tests: true poses and points, and observations of them.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "core/camera.h"
#include "core/observation.h"
#include "core/pose.h"

namespace ieslam {

// A small self-contained scene: a camera sliding sideways (and a little up and forward)
// past a box of points in front of it, with a little random rotation at each pose.
struct Scene {
  PinholeCamera camera;
  std::vector<int> frame_ids;
  std::vector<Vector6d> poses;  // true T_w_c
  std::vector<int64_t> feature_ids;
  std::vector<Eigen::Vector3d> points;  // true p_w
};

inline PinholeCamera TestCamera() {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 500.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  return camera;
}

inline Scene MakeScene(int num_poses, int num_points, std::mt19937* rng) {
  Scene scene;
  scene.camera = TestCamera();
  std::uniform_real_distribution<double> x(-3.0, 3.0 + 0.6 * num_poses), y(-2.5, 2.5), z(3.0, 7.0),
      small(-0.08, 0.08);
  for (int j = 0; j < num_points; ++j) {
    scene.feature_ids.push_back(1000 + 7 * j);  // sparse, stable ids
    scene.points.emplace_back(x(*rng), y(*rng), z(*rng));
  }
  for (int i = 0; i < num_poses; ++i) {
    scene.frame_ids.push_back(10 * i + 3);
    Vector6d pose;
    pose << 0.6 * i + small(*rng), small(*rng), 0.05 * i + small(*rng), small(*rng), small(*rng),
        small(*rng);
    scene.poses.push_back(pose);
  }
  return scene;
}

// The features pose i sees, with noise of sigma 0.5 px and 5 mm + 0.5% of the range.
inline std::vector<FeatureObservation> Observe(const Scene& scene, int i, bool noisy,
                                               std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<FeatureObservation> observations;
  for (size_t j = 0; j < scene.points.size(); ++j) {
    if (WorldToCamera(scene.poses[i], scene.points[j]).z() < 0.5) continue;
    const Eigen::Vector3d z = PredictObservation(scene.poses[i], scene.points[j], scene.camera);
    if (!scene.camera.InImage(z.head<2>())) continue;
    FeatureObservation obs;
    obs.feature_id = scene.feature_ids[j];
    const Eigen::Vector3d sigma(0.5, 0.5, 0.005 + 0.005 * z.z());
    obs.Q = sigma.cwiseAbs2().asDiagonal();
    obs.z = z;
    if (noisy)
      obs.z += sigma.cwiseProduct(Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)));
    observations.push_back(obs);
  }
  return observations;
}

// `pose` moved by Gaussian noise of `metres` and `radians` per component.
inline Vector6d Perturb(const Vector6d& pose, double metres, double radians, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Vector6d perturbed = pose;
  for (int k = 0; k < 3; ++k) perturbed[k] += metres * normal(*rng);
  for (int k = 3; k < 6; ++k) perturbed[k] += radians * normal(*rng);
  return perturbed;
}

// Runs the same noisy sequence of the scene's first `num_poses` poses through two filters
// (the sparse one and the dense reference, or two sparse ones), each pose from a perturbed
// initial value.
template <typename FilterA, typename FilterB>
void RunBoth(const Scene& scene, int num_poses, std::mt19937* rng, FilterA* a, FilterB* b) {
  const std::vector<FeatureObservation> first = Observe(scene, 0, true, rng);
  a->AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  b->AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  for (int i = 1; i < num_poses; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, true, rng);
    const Vector6d initial = Perturb(scene.poses[i], 0.02, 0.01, rng);
    a->AddPose(scene.frame_ids[i], initial, observations);
    b->AddPose(scene.frame_ids[i], initial, observations);
  }
}

// Both filters fed the scene's first num_poses poses at the truth, noise-free: both are
// linearised at the same points.
template <typename FilterA, typename FilterB>
void RunBothAtTheTruth(const Scene& scene, int num_poses, std::mt19937* rng, FilterA* a,
                       FilterB* b) {
  for (int i = 0; i < num_poses; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, false, rng);
    if (i == 0) {
      a->AddFirstPose(scene.frame_ids[0], scene.poses[0], observations);
      b->AddFirstPose(scene.frame_ids[0], scene.poses[0], observations);
    } else {
      a->AddPose(scene.frame_ids[i], scene.poses[i], observations);
      b->AddPose(scene.frame_ids[i], scene.poses[i], observations);
    }
  }
}

}  // namespace ieslam
