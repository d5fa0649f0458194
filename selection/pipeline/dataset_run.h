// `ieslam run` as a library call: a dataset's frames through the image front end
// (frontend/rgbd_frame_source.h) into the pipeline (selection/pipeline/pipeline.h), and what
// a run reports beyond the estimate: the trajectories with the dataset's timestamps, the
// skipped frames, the dense map, the ATE against the dataset's ground truth, the timings.
// Nothing is written; selection/pipeline/run_outputs.h writes a run's files.
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "backend/evaluation/consistency.h"
#include "core/dataset.h"
#include "core/json.h"
#include "core/range_cloud.h"
#include "core/trajectory.h"
#include "frontend/dense_map.h"
#include "frontend/rgbd_frame_source.h"
#include "selection/pipeline/continued_dataset.h"
#include "selection/pipeline/pipeline.h"
#include "selection/pipeline/run_options.h"
#include "selection/pipeline/saved_map.h"

namespace ieslam {

struct RunResult {
  PipelineResult pipeline;
  SourceTimings frontend;
  // A rolling-shutter rig's compensation: how many frames had a velocity from both of their
  // neighbours, one or none, and the angular rates of those that had one.
  std::optional<FrameVelocities::Counts> velocity_counts;
  std::vector<double> angular_rates_rad_s;
  // Of the selected frames (in time order) and of every placed frame (in frame order), with
  // the dataset's timestamps; the dataset's ground truth of the selected frames.
  Trajectory keyframes;
  Trajectory trajectory;
  Trajectory ground_truth;
  // The timestamp of every pose of the pipeline's problem.
  std::map<int, double> timestamps;
  // Frames looked at and not placed: (index in the dataset, reason).
  std::vector<std::pair<int, std::string>> frames_skipped;
  std::optional<DenseMap> map;  // with options.build_map
  // With options.save_map and a filter holding poses: what OUT/map/ holds.
  std::optional<SavedMap> saved_map;
  // ATE RMSE against the ground truth as `ieslam evaluate` computes it from the written
  // files (the trajectories rounded as a TUM file holds them); < 0 where it cannot be
  // computed (no ground truth, fewer than 3 poses associated).
  double ate_keyframes_m = -1.0;
  double ate_trajectory_m = -1.0;
  double ate_refined_m = -1.0;
  // With the depth correction applied (Refinement::corrected): the refinement without it.
  double ate_refined_uncorrected_m = -1.0;
  // The stated pose covariances against the ground truth (same origin as the estimate, no
  // alignment fitted): the filter's, and the refinement's when it computed them
  // (ba.compute_covariances); nullopt where there is nothing to compare.
  std::optional<PoseConsistency> consistency_filter;
  std::optional<PoseConsistency> consistency_refined;
  std::chrono::steady_clock::time_point started;
  // Wall time on the caller's thread outside the pipeline's own stages: opening the frame
  // source, loading the selected frames' depth for the map after the pipeline (the pipeline's
  // clouds_seconds holds the load it asked for) and building the saved map (both in `map`),
  // and the trajectories, ATE and consistency.
  double setup_seconds = 0.0;
  double map_seconds = 0.0;
  double evaluation_seconds = 0.0;
  // The dataset's calibration with the refinement's estimated depth correction
  // (CorrectedCalibration), written as corrected_calib.yaml.
  std::optional<Rig> corrected_calibration;
  std::vector<std::string> warnings;  // things the user should hear about, one line each
  // Continued from a saved map (ContinueMapping): its file, and its keyframes, which are the
  // frames before map_frames.
  std::string continued_map_file;
  int map_frames = 0;
  double map_load_seconds = 0.0;  // reading that map, as the caller timed it

  // hooks.stop said so after the selection (in the refinement or the map); the map then
  // holds the frames loaded before.
  bool stopped_after_selection = false;

  int frames_processed() const { return pipeline.selection.frames_processed; }
  bool interrupted() const { return pipeline.selection.interrupted || stopped_after_selection; }
  // The refinement to write as refined.tum: there and not failed.
  bool refined() const { return pipeline.refinement && pipeline.refinement->ok(); }
};

// Runs the whole job on `dataset` (opened with options.dataset_options). A refinement that
// failed or was interrupted comes back with its `failure` and a warning. Throws ConfigError
// for options failing Check(); DataError from the dataset propagates.
RunResult RunOnDataset(const Dataset& dataset, const RunOptions& options,
                       const PipelineHooks& hooks = {});

// The same, going on from the saved map `dataset` continues: the filter resumes from the map's
// state, its keyframes are base frames from the start, and new keyframes and features join
// them, so that the result (and its saved map) is one map of both sessions. The outputs cover
// the map's keyframes as frames 0 .. map_frames-1 (ContinuedDataset); without their images
// (ContinuedDataset::map_images) they are left out of the dense map and the depth alignment,
// with a warning. Throws as RunOnDataset, and ConfigError for dead reckoning, which keeps no
// filter to go on with.
RunResult ContinueMapping(const ContinuedDataset& dataset, const RunOptions& options,
                          const PipelineHooks& hooks = {});

}  // namespace ieslam
