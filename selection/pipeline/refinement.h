// The batch refinement of a filter's estimate: the bundle adjustment of its problem (the
// smoother, the reference the filter is checked against), with the problem's registered
// observations a second one on every observation the front end registered, and, given range
// clouds of the frames, the dense alignment of their surfaces on top of that
// (backend/depth_alignment.h). `ieslam run --refine` and `ieslam refine` both refine through
// here.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "backend/bundle_adjustment.h"
#include "backend/depth_alignment.h"
#include "backend/depth_correction.h"
#include "backend/evaluation/filter_smoother_comparison.h"
#include "backend/slam_estimate.h"
#include "core/camera.h"
#include "core/json.h"
#include "core/range_cloud.h"
#include "core/trajectory.h"

namespace ieslam {

// The range clouds of a problem's frames (by frame id), and how many of its frames have none.
struct RangeClouds {
  std::map<int, RangeCloud> clouds;
  int frames_left_out = 0;
};

struct Refinement {
  // The bundle adjustment of the features the filter observed, with the observations it
  // took: the smoother the filter is checked against. Without covariances when another solve
  // is the refinement (that one has its own).
  BundleAdjustmentResult smoothed;
  // The filter's estimate against `smoothed`.
  FilterSmootherComparison comparison;
  // With BundleAdjustmentOptions::refine_registered and a problem with `registered`
  // observations (the gate took some otherwise): the bundle adjustment of the features with
  // those (every registered observation, its stated Q), from the filter's estimate; the
  // refinement's features when usable (a failure other than an interruption leaves that to
  // `smoothed`, with a warning).
  bool registered_tried = false;
  bool registered_used = false;
  BundleAdjustmentResult registered;
  int refused = 0;       // registered observations the filter's gate refused (when tried)
  int refused_kept = 0;  // of them, what `registered`'s rejection rounds kept (when used)
  // The filter's estimate against `registered` (when used): how far the filter is from the
  // adjustment of all the data, not only of what it took.
  FilterSmootherComparison registered_comparison;
  // Tried when clouds were given, the depth options ask for rounds and the features' solve
  // (`registered` when used, else `smoothed`) is usable; used when that solve is usable too
  // (else the refinement is the features' solve, with a warning).
  bool depth_alignment_tried = false;
  bool depth_alignment_used = false;
  BundleAdjustmentResult depth_aligned;
  DepthAlignmentStats depth_stats;
  int depth_frames = 0;  // frames with a cloud
  int depth_frames_left_out = 0;
  // Where depth_aligned differs from the features' solve it started from (when tried).
  FilterSmootherComparison change_from_features;
  // With BundleAdjustmentOptions::estimate_depth_correction, once the check's solve is usable:
  // the range imager's depth correction its observations imply.
  bool depth_correction_tried = false;
  DepthCorrectionEstimate depth_correction;
  // With BundleAdjustmentOptions::apply_depth_correction and a usable estimate: the same
  // refinement again with every range of the problem and the clouds corrected by it
  // (WithRangesCorrected), and where its refined estimate differs from this one's. Null when
  // not asked for, or when it failed (with a warning; an interruption is `failure`).
  std::shared_ptr<const Refinement> corrected;
  FilterSmootherComparison change_from_uncorrected;
  double seconds = 0.0;  // every solve
  std::vector<std::string> warnings;
  // Why there is no refinement to use: the problem has no observations, the bundle
  // adjustment's solve is not usable, or it was interrupted (ba.stop); empty when refined()
  // is a usable, complete solve. A failed refinement is never written as refined.tum.
  std::string failure;

  bool ok() const { return failure.empty(); }

  // The features' solve the refinement rests on: registered when used, else smoothed.
  const BundleAdjustmentResult& features() const { return registered_used ? registered : smoothed; }
  // The refined estimate of the ranges as read: depth_aligned when used, else features().
  const BundleAdjustmentResult& uncorrected_refined() const {
    return depth_alignment_used ? depth_aligned : features();
  }
  // The refined estimate: the corrected refinement's when there is one, else
  // uncorrected_refined().
  const BundleAdjustmentResult& refined() const {
    return corrected ? corrected->refined() : uncorrected_refined();
  }
};

// Bundle-adjusts `problem` (started from its poses and features) and compares the result with
// `filter_estimate`; with ba.refine_registered, bundle-adjusts it again with its registered
// observations (when it has them); with `clouds` and depth.rounds > 0, goes on with the clouds'
// pairwise alignments; with ba.estimate_depth_correction, estimates the range imager's depth
// correction from the check's solve (the range imager placed by T_colour_range), and with
// ba.apply_depth_correction refines again with it applied (Refinement::corrected). An
// interruption (ba.stop) anywhere, like a failure of the check's
// bundle adjustment (the one the filter is compared with) or of the depth-aligned refinement's
// fallback, is `failure`: a half-done refinement is no refinement.
Refinement Refine(const BundleAdjustmentProblem& problem, const PinholeCamera& camera,
                  const SlamEstimate& filter_estimate, const BundleAdjustmentOptions& ba,
                  const DepthAlignmentOptions& depth, const RangeClouds* clouds = nullptr,
                  const Eigen::Isometry3d& T_colour_range = Eigen::Isometry3d::Identity());

// The poses of `solved` with their frames' timestamps (`timestamps` holds every frame's), in
// time order.
Trajectory SolvedTrajectory(const BundleAdjustmentResult& solved,
                            const std::map<int, double>& timestamps);
// SolvedTrajectory of the refined estimate (Refinement::refined).
Trajectory RefinedTrajectory(const Refinement& refinement, const std::map<int, double>& timestamps);

// `rig` with the refinement's depth correction applied (WithDepthCorrection) when it has a
// usable one: the calibration a next run reads (corrected_calib.yaml). None otherwise, with a
// warning when the correction was usable but the corrected rig fails Rig::Check.
std::optional<Rig> CorrectedCalibration(const Refinement& refinement, const Rig& rig,
                                        std::vector<std::string>* warnings);

// A report's filter_vs_smoother: the comparison, the solver's summary as "ba" and, when tried,
// "registered" (the registered solve's counts, summary and comparison), "depth_alignment" and
// "depth_correction".
Json RefinementToJson(const Refinement& refinement);

}  // namespace ieslam
