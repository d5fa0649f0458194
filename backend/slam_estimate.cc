#include "backend/slam_estimate.h"

#include "backend/bundle_adjustment.h"
#include "backend/information_filter.h"

namespace ieslam {

SlamEstimate FilterEstimate(const InformationFilter& filter, bool with_covariances) {
  SlamEstimate estimate;
  for (int frame_id : filter.frame_ids()) {
    estimate.poses[frame_id] = filter.pose(frame_id);
    if (with_covariances) estimate.pose_covariances[frame_id] = filter.PoseCovariance(frame_id);
  }
  for (int64_t feature_id : filter.feature_ids()) {
    estimate.features[feature_id] = filter.feature(feature_id);
  }
  return estimate;
}

SlamEstimate SmootherEstimate(const BundleAdjustmentResult& result) {
  SlamEstimate estimate;
  estimate.poses = result.poses;
  estimate.pose_covariances = result.pose_covariances_euler;
  estimate.features = result.p_w;
  return estimate;
}

}  // namespace ieslam
