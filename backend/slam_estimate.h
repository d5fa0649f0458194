// What one estimator says about the selected poses and the features: the filter's estimate
// (with its marginal pose covariances) and the bundle adjustment's, in one form, so that the
// two can be compared and reported alike.
#pragma once

#include <cstdint>
#include <map>

#include <Eigen/Core>

#include "core/pose.h"

namespace ieslam {

class InformationFilter;
struct BundleAdjustmentResult;

struct SlamEstimate {
  std::map<int, Vector6d> poses;  // the paper's 6-vector, camera-to-world, by frame id
  // Over the Euler 6-vector, as InformationFilter::PoseCovariance; may be empty.
  std::map<int, Matrix6d> pose_covariances;
  std::map<int64_t, Eigen::Vector3d> features;
};

// The filter's estimate; its pose covariances when `with_covariances` (one marginal
// recovery per pose).
SlamEstimate FilterEstimate(const InformationFilter& filter, bool with_covariances = true);
// The bundle adjustment's estimate, with its Euler-tangent covariances when it computed them.
SlamEstimate SmootherEstimate(const BundleAdjustmentResult& result);

}  // namespace ieslam
