// One run of a selector and the filter over a sequence with known data association and
// known truth (the paper's simulation), with the numbers of the paper's Table I and its
// consistency figures: frames used, state dimension, time, errors, NEES.
#pragma once

#include <vector>

#include "backend/bundle_adjustment.h"
#include "backend/information_filter.h"
#include "selection/keyframe_selector.h"

namespace ieslam {

struct KnownAssociationInput {
  std::vector<std::vector<FeatureObservation>> observations;  // per frame, global feature ids
  std::vector<Vector6d> T_w_c_true;                           // per frame
  PinholeCamera camera;
};

struct PoseErrorRecord {
  int frame = -1;
  Vector6d error = Vector6d::Zero();  // estimate - truth, angles wrapped
  Vector6d sigma = Vector6d::Zero();  // sqrt of the marginal covariance's diagonal
  double nees = 0.0;
};

struct KnownAssociationMetrics {
  int frames_total = 0;
  int frames_used = 0;
  int state_dim = 0;
  int poses = 0;
  int features = 0;
  double seconds = 0.0;  // selection + filter
  double seconds_selection = 0.0;
  double seconds_filter = 0.0;
  double final_pose_error_m = 0.0;  // translation error of the last selected pose
  double ate_rmse_m = 0.0;          // selected poses, Horn-aligned as the TUM tools do
  double mean_nees = 0.0;           // over the selected poses (final estimates)
  double within_2sigma = 0.0;       // fraction of (pose, axis) errors inside +-2 sigma
  // With a refinement: the bundle adjustment of the selected poses and their features,
  // started from the filter's estimate (< 0: not refined), and its solve's seconds. With the
  // observation gate that is the refinement's adjustment (Refinement::refined()), not the
  // check's.
  double refined_ate_rmse_m = -1.0;
  double seconds_ba = 0.0;
  std::vector<PoseErrorRecord> pose_errors;
  SelectionResult selection;
};

// The first pose is anchored at its true value, so estimates and truth share a frame. With
// `refine`, the filter's estimate is then bundle-adjusted with those options.
KnownAssociationMetrics RunKnownAssociation(const KnownAssociationInput& input,
                                            const SelectorOptions& selector,
                                            const InformationFilterOptions& filter,
                                            const BundleAdjustmentOptions* refine = nullptr);

}  // namespace ieslam
