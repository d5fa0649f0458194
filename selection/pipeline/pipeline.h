// The estimator as one call: frames of a FrameSource go through the keyframe selector into
// the information filter; with `refine`, the filter's problem is then bundle-adjusted (and,
// given range clouds of the selected frames, aligned densely as well). Everything comes back
// in memory; writing files is the caller's business (selection/pipeline/run_outputs.h).
//
// The image front end (selection/pipeline/dataset_run.h) and the paper's simulation
// (selection/pipeline/known_association_run.h) both run through RunPipeline.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "backend/bundle_adjustment.h"
#include "backend/depth_alignment.h"
#include "backend/information_filter.h"
#include "backend/slam_estimate.h"
#include "core/camera.h"
#include "core/frame_source.h"
#include "core/option_table.h"
#include "selection/keyframe_selector.h"
#include "selection/pipeline/refinement.h"

namespace ieslam {

struct PipelineOptions {
  SelectorOptions selector;
  InformationFilterOptions filter;
  bool refine = false;  // bundle-adjust the selected frames after the filter
  BundleAdjustmentOptions ba;
  // With refine and range clouds: the clouds' pairwise alignment in the refinement.
  DepthAlignmentOptions depth_alignment;

  // `refine` (the stages' options have their own tables).
  static const OptionTable<PipelineOptions>& Table();
  // Every stage's options and the table's.
  bool Check(std::string* why) const;
};

// What the caller sees while the pipeline runs; every member is optional.
struct PipelineHooks {
  // (frames done, frames selected), after each selector step.
  std::function<void(int, int)> progress;
  // Polled between selector decisions and in the refinement's iterations: true ends the
  // selection there (result.selection.interrupted) with everything decided so far estimated;
  // a refinement it interrupts, or that starts after it, is no refinement (its `failure`).
  std::function<bool()> stop;
  std::function<void(const SelectionDecision&)> on_decision;
  // Once the selection is over, before the source lets go of its frames: what the caller
  // wants of them (a saved map's base frames), with the filter that holds the selected poses.
  std::function<void(const SelectionResult&, const InformationFilter&)> before_finish;
};

// The range clouds of the selected frames for the depth alignment: called once, after the
// selection, with the selected frames in the order they were selected and every frame's
// estimated pose (PipelineResult::T_w_c); only with refine and depth_alignment.rounds > 0.
using RangeCloudLoader = std::function<RangeClouds(
    const std::vector<int>& selected, const std::vector<std::optional<Eigen::Isometry3d>>& T_w_c)>;

// Mapping continued from a saved map: the filter as it stood (renumbered so that its poses are
// the source's first frames) and the selection it held.
struct PipelineResume {
  FilterSnapshot filter;
  SelectionResume selection;
};

struct PipelineResult {
  SelectionResult selection;
  // The filter with every selected pose and feature (empty for dead reckoning).
  std::unique_ptr<InformationFilter> filter;
  // Every frame of the source: the filter's estimate for selected frames, the base frame's
  // composed with the registration for the others; nullopt where the frame was not placed.
  std::vector<std::optional<Eigen::Isometry3d>> T_w_c;
  // With a filter holding poses: its estimate with the pose covariances, and the bundle-
  // adjustment problem it defines (its estimate, the observations and Q it used, and where
  // its observation gate took them otherwise every registered observation).
  bool has_estimate = false;
  SlamEstimate estimate;
  BundleAdjustmentProblem problem;
  std::optional<Refinement> refinement;  // with refine
  double covariance_seconds = 0.0;       // recovering the pose covariances
  // Wall time on the caller's thread: the selector's run over the frames (every frame's
  // registration, scoring and filter update), and loading the range clouds for the
  // refinement (with the dense map when the caller's loader builds it).
  double selection_wall_seconds = 0.0;
  double clouds_seconds = 0.0;
};

// Runs the selector over every frame of `source` (observations in `camera`'s model) into a
// new filter, recovers the estimate and, with options.refine, refines it (range clouds from
// `clouds` when set). With `resume`, the filter starts from its snapshot and the selector
// goes on after the frames it holds (KeyframeSelector::Run). Throws ConfigError for options
// failing Check(); DataError from the source or a snapshot that does not hold together
// propagates. T_colour_range places the range imager for the refinement's depth correction.
PipelineResult RunPipeline(FrameSource* source, const PinholeCamera& camera,
                           const PipelineOptions& options, const PipelineHooks& hooks = {},
                           const RangeCloudLoader& clouds = nullptr,
                           const PipelineResume* resume = nullptr,
                           const Eigen::Isometry3d& T_colour_range = Eigen::Isometry3d::Identity());

}  // namespace ieslam
