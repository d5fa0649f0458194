// The bundle adjustment's parameter blocks and solver settings, shared by its solves
// (backend/bundle_adjustment.cc) and the depth correction's (backend/depth_correction.cc).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

#include <ceres/solver.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "backend/bundle_adjustment.h"

namespace ieslam {
namespace ba_internal {

// The parameter blocks Ceres works on, all in one buffer laid out in frame-id then
// feature-id order: 4 quaternion (Eigen x, y, z, w) + 3 translation doubles per pose, then 3
// per feature. One buffer matters for reproducibility, not only locality: Ceres keeps the
// blocks of an elimination group in a set ordered by address, so blocks allocated one by one
// would be ordered (and factored) differently from one solve to the next.
class Parameters {
 public:
  explicit Parameters(const BundleAdjustmentProblem& problem) {
    buffer_.resize(7 * problem.T_w_c.size() + 3 * problem.p_w.size());
    size_t offset = 0;
    for (const auto& [frame_id, T] : problem.T_w_c) {
      pose_offset_[frame_id] = offset;
      Eigen::Map<Eigen::Vector4d> q_w_c(&buffer_[offset]);
      Eigen::Map<Eigen::Vector3d> t_w_c(&buffer_[offset + 4]);
      q_w_c = Eigen::Quaterniond(T.linear()).normalized().coeffs();
      t_w_c = T.translation();
      offset += 7;
    }
    for (const auto& [feature_id, p_w] : problem.p_w) {
      feature_offset_[feature_id] = offset;
      Eigen::Map<Eigen::Vector3d> p(&buffer_[offset]);
      p = p_w;
      offset += 3;
    }
  }
  Parameters(const Parameters&) = delete;
  Parameters& operator=(const Parameters&) = delete;

  bool HasPose(int frame_id) const { return pose_offset_.count(frame_id) > 0; }
  bool HasFeature(int64_t feature_id) const { return feature_offset_.count(feature_id) > 0; }
  double* q_w_c(int frame_id) { return &buffer_[pose_offset_.at(frame_id)]; }
  double* t_w_c(int frame_id) { return &buffer_[pose_offset_.at(frame_id) + 4]; }
  double* p_w(int64_t feature_id) { return &buffer_[feature_offset_.at(feature_id)]; }
  const std::map<int, size_t>& pose_offsets() const { return pose_offset_; }
  const std::map<int64_t, size_t>& feature_offsets() const { return feature_offset_; }

  Eigen::Isometry3d Pose(int frame_id) const {
    const double* x = &buffer_[pose_offset_.at(frame_id)];
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() =
        Eigen::Quaterniond(Eigen::Map<const Eigen::Vector4d>(x)).normalized().toRotationMatrix();
    T.translation() = Eigen::Map<const Eigen::Vector3d>(x + 4);
    return T;
  }
  Eigen::Vector3d Feature(int64_t feature_id) const {
    return Eigen::Map<const Eigen::Vector3d>(&buffer_[feature_offset_.at(feature_id)]);
  }

 private:
  std::vector<double> buffer_;
  std::map<int, size_t> pose_offset_;
  std::map<int64_t, size_t> feature_offset_;
};

// Levenberg-Marquardt as BundleAdjustmentOptions say: iterations, tolerances, first trust
// region, threads; CHOLMOD for sparse factors; silent.
inline void SetLevenbergMarquardt(const BundleAdjustmentOptions& options,
                                  ceres::Solver::Options* solver) {
  solver->minimizer_type = ceres::TRUST_REGION;
  solver->trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver->sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver->max_num_iterations = options.max_iterations;
  solver->function_tolerance = options.function_tolerance;
  solver->gradient_tolerance = options.gradient_tolerance;
  solver->parameter_tolerance = options.parameter_tolerance;
  solver->initial_trust_region_radius = options.initial_trust_region_radius;
  // A step the linear solver cannot take (a near-singular system) shrinks the region as a
  // failed one does; from the Gauss-Newton start the tenth such step is at a radius below
  // Ceres' default, where its default of five would end the solve before getting there.
  solver->max_num_consecutive_invalid_steps = 10;
  solver->num_threads = options.num_threads;
  solver->logging_type = ceres::SILENT;
  solver->minimizer_progress_to_stdout = false;
}

}  // namespace ba_internal
}  // namespace ieslam
