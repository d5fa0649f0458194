// Filter versus smoothing, the check ieslam adds to the paper's filter: how far the
// information filter's estimate of the selected poses and features lies from the bundle
// adjustment's over the same observations, and whether that distance is within what the
// filter's own covariance claims.
//
// The filter linearises each observation once, at the estimate of its time; the bundle
// adjustment relinearises everything to convergence. Differences far beyond the filter's
// sigmas (large Mahalanobis distances) point at linearisation error or an overconfident
// filter rather than at noise.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "backend/evaluation/error_stats.h"
#include "backend/slam_estimate.h"
#include "core/json.h"
#include "core/pose.h"

namespace ieslam {

struct FramePoseComparison {
  int frame_id = -1;
  Vector6d difference = Vector6d::Zero();  // PoseDifference(filter, smoother)
  double translation_m = 0.0;              // |t_filter - t_smoother|
  double rotation_deg = 0.0;               // angle of R_filter^T R_smoother
  // sqrt(d^T P^-1 d), d = difference, P the filter's pose covariance; NaN without one (or
  // when P is not positive definite).
  double mahalanobis = 0.0;
};

// The summaries are ComputeFiniteErrorStats of the per-frame (per-feature) values: a frame
// without a usable covariance has a NaN Mahalanobis distance, which they skip.
struct FilterSmootherComparison {
  std::vector<FramePoseComparison> frames;  // frames both estimates hold, by id
  ErrorStats translation_m;
  ErrorStats rotation_deg;
  ErrorStats mahalanobis;
  // Mean of d^T P^-1 d over the frames: ~6 when the filter's covariance is right and the
  // smoother is much closer to the truth than the filter.
  double mean_squared_mahalanobis = 0.0;
  ErrorStats feature_m;  // |p_filter - p_smoother| over the common features
  int frames_only_in_filter = 0;
  int frames_only_in_smoother = 0;
};

FilterSmootherComparison CompareFilterToSmoother(const SlamEstimate& filter,
                                                 const SlamEstimate& smoother);

// Each summary as {count, rmse, mean, max}; the frames' comparisons when `per_frame`.
Json ComparisonToJson(const FilterSmootherComparison& comparison, bool per_frame = true);

}  // namespace ieslam
