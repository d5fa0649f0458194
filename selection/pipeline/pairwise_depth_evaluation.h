// Dense alignment of frame i+K's range image onto frame i's across a dataset, started from the
// ground truth: where the range images' own optimum near the truth lies (`ieslam register
// --dense`), as `ieslam refine --from-ground-truth` finds the bundle adjustment's.
//
// The features' registration (frontend/pairwise_evaluation.h) checks the colour camera, the
// lifting and the matching; this checks the range imager alone, with the refinement's
// point-to-plane alignment (backend/depth_alignment.h). Both take the frames as the sensor gives
// them, without the rolling-shutter compensation of a run, so that they are compared alike. An
// error of the depth (a tilt, a wrong scale) moves both off the truth; what only the features
// show is the colour side's. Two things keep the dense figures from being the depth's error
// alone: along directions the scene's surfaces do not constrain (planes facing the
// camera), the alignment stays near where it was started; and the ground truth is the pose at
// the colour image's time, so a range image taken at another time carries the motion between.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "backend/depth_alignment.h"
#include "core/dataset.h"
#include "core/range_cloud.h"
#include "frontend/pairwise_evaluation.h"

namespace ieslam {

struct DepthPairRecord {
  int frame_a = 0;  // as the user numbers frames (before --first)
  int frame_b = 0;
  bool aligned = false;  // PairAlignment::usable: enough overlap, correspondences, a small spread
  bool success = false;  // ... and it is within the error limits
  std::string reason;    // why not aligned
  int correspondences = 0;
  double translation_error_m = 0.0;
  double rotation_error_deg = 0.0;
  // The aligned T_a_b's translation minus the ground truth's, in frame a's camera (x right,
  // y down, z along the optical axis).
  Eigen::Vector3d translation_error_a = Eigen::Vector3d::Zero();
};

struct DepthPairwiseReport : PairErrorSummary {
  std::vector<DepthPairRecord> pairs;
};

// Aligns the range cloud of frame i+K (options.step) onto frame i's for every i, from their
// ground-truth relative pose, each cloud as of one instant (no rolling-shutter row motion). A
// pair succeeds when it aligns within options' error limits (PairwiseOptions::min_inliers is the
// features' and plays no part: the alignment's own min_correspondences does). Throws
// ConfigError for options failing Check() and DataError for too few frames, for no pair
// with ground truth, or for a range image that does not load (naming it). `progress` and
// `stop` as EvaluatePairwiseRegistration's.
DepthPairwiseReport EvaluatePairwiseDepthAlignment(
    const Dataset& dataset, const PairwiseOptions& options, const RangeCloudOptions& clouds,
    const DepthAlignmentOptions& alignment, const std::function<void(int, int)>& progress = nullptr,
    const std::function<bool()>& stop = nullptr);

}  // namespace ieslam
