#include "selection/pipeline/dataset_run.h"

#include <algorithm>
#include <functional>

#include <opencv2/core.hpp>

#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "core/error.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

// ATE RMSE of `est` against `gt_read_back` (the ground truth as read back from its file) as
// `ieslam evaluate` computes it from their files; -1 with a warning when it cannot be
// computed (a run that lost track early still reports).
double Ate(const Trajectory& gt_read_back, const Trajectory& est, const std::string& what,
           std::vector<std::string>* warnings) {
  try {
    return ComputeAte(gt_read_back, AsReadBackFromTum(est, what), EvaluationOptions(),
                      "groundtruth.tum", what)
        .translation.rmse;
  } catch (const DataError& e) {
    warnings->push_back("no ATE for " + what + ": " + e.what());
    return -1.0;
  }
}

// `estimate`'s covariances against the ground truth; nullopt when no pose could be compared.
// Ground truth is interpolated over gaps up to twice the ATE's association window: two
// samples each within the window of a frame's stamp.
std::optional<PoseConsistency> Consistency(const Trajectory& ground_truth,
                                           const std::map<int, double>& timestamps,
                                           const SlamEstimate& estimate) {
  if (estimate.pose_covariances.empty()) return std::nullopt;
  const double max_gap_s = 2.0 * EvaluationOptions().max_diff_s;
  const PoseConsistency c = EvaluatePoseConsistency(
      estimate.poses, estimate.pose_covariances,
      TruthInEstimateFrame(ground_truth, timestamps, estimate.poses, max_gap_s));
  if (c.poses == 0) return std::nullopt;
  return c;
}

// Loads each of `frames` once, in the given order, into the dense map (at its pose in
// `T_w_c`) and, when `clouds` is set, as a range cloud. A frame that cannot be loaded again,
// or whose range image gives no cloud, is left out with a warning. Stops early, setting
// *stopped, once `stop` (when set) says so.
void LoadSelectedFrames(const Dataset& dataset, const std::vector<int>& frames,
                        const std::vector<std::optional<Eigen::Isometry3d>>& T_w_c,
                        const RangeCloudOptions& cloud_options, DenseMap* map, RangeClouds* clouds,
                        const std::function<bool()>& stop, bool* stopped,
                        std::vector<std::string>* warnings) {
  const std::string uses = map != nullptr && clouds != nullptr ? "the map and the depth alignment"
                           : map != nullptr                    ? "the map"
                                                               : "the depth alignment";
  for (const int frame : frames) {
    if (stop && stop()) {
      *stopped = true;
      return;
    }
    if (!T_w_c[frame]) continue;
    const std::string name = "frame " + std::to_string(frame);
    Frame loaded;
    try {
      loaded = dataset.Load(frame);
    } catch (const DataError& e) {
      warnings->push_back(name + " left out of " + uses + ": " + e.what());
      if (clouds != nullptr) ++clouds->frames_left_out;
      continue;
    }
    if (map != nullptr) map->AddFrame(loaded, dataset.rig(), *T_w_c[frame]);
    if (clouds == nullptr) continue;
    try {
      clouds->clouds[frame] = MakeRangeCloud(loaded.depth, dataset.rig().range,
                                             dataset.rig().T_colour_range, cloud_options, name);
    } catch (const DataError& e) {
      warnings->push_back(name + " left out of the depth alignment: " + e.what());
      ++clouds->frames_left_out;
    }
  }
}

// The trajectories and skipped frames of the pipeline's result, with the dataset's stamps.
void CollectTrajectories(const Dataset& dataset, RunResult* run) {
  const PipelineResult& p = run->pipeline;
  for (const int frame : p.selection.selected) {
    if (p.T_w_c[frame]) run->keyframes.push_back({dataset.info(frame).timestamp, *p.T_w_c[frame]});
  }
  std::sort(run->keyframes.begin(), run->keyframes.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.timestamp < b.timestamp; });
  for (int f = 0; f < p.selection.frames_processed; ++f) {
    if (p.T_w_c[f]) {
      run->trajectory.push_back({dataset.info(f).timestamp, *p.T_w_c[f]});
    } else {
      run->frames_skipped.emplace_back(dataset.info(f).source_index,
                                       p.selection.frames[f].skip_reason);
    }
  }
  for (const auto& [frame, T] : p.problem.T_w_c)
    run->timestamps[frame] = dataset.info(frame).timestamp;
  if (dataset.has_ground_truth()) run->ground_truth = dataset.GroundTruth();
}

}  // namespace

RunResult RunOnDataset(const Dataset& dataset, const RunOptions& options,
                       const PipelineHooks& hooks) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  RunResult run;
  run.started = std::chrono::steady_clock::now();
  // OpenCV's TBB back end warns on stderr when asked for more threads than there are cores.
  if (options.threads > 0) cv::setNumThreads(std::min(options.threads, WorkerThreads(0)));
  const RunOptions used = options.Resolved();
  RgbdFrameSource source(dataset, used.source);
  if (used.build_map) run.map.emplace(used.map);
  // A stop the selection obeyed ends the selection only: the frames it processed are still
  // mapped and refined (a second signal ends the process). The later stages obey a stop
  // that comes after the selection's end.
  bool selection_stopped = false;
  PipelineHooks pipeline_hooks = hooks;
  if (hooks.stop) {
    pipeline_hooks.stop = [&] { return selection_stopped = selection_stopped || hooks.stop(); };
  }
  const std::function<bool()> loader_stop = [&] {
    return !selection_stopped && hooks.stop && hooks.stop();
  };
  // With depth alignment, each selected frame is loaded once for both the map and its cloud.
  bool map_built = false;
  const RangeCloudLoader clouds = [&](const std::vector<int>& frames,
                                      const std::vector<std::optional<Eigen::Isometry3d>>& T_w_c) {
    RangeClouds loaded;
    LoadSelectedFrames(dataset, frames, T_w_c, used.range_cloud, run.map ? &*run.map : nullptr,
                       &loaded, loader_stop, &run.stopped_after_selection, &run.warnings);
    map_built = true;
    return loaded;
  };
  run.pipeline = RunPipeline(&source, dataset.rig().colour, used.pipeline, pipeline_hooks, clouds);
  run.frontend = source.timings();
  CollectTrajectories(dataset, &run);
  if (run.map && !map_built) {
    const bool selection_interrupted = run.pipeline.selection.interrupted;
    const std::function<bool()> map_stop = [&] {
      return !selection_interrupted && hooks.stop && hooks.stop();
    };
    LoadSelectedFrames(dataset, run.pipeline.selection.selected, run.pipeline.T_w_c,
                       used.range_cloud, &*run.map, nullptr, map_stop, &run.stopped_after_selection,
                       &run.warnings);
  }
  // A stop in the refinement or the map, where the selection no longer polls.
  if (!run.pipeline.selection.interrupted && hooks.stop && hooks.stop()) {
    run.stopped_after_selection = true;
  }
  if (run.pipeline.refinement && !run.pipeline.refinement->ok()) {
    run.warnings.push_back("no refinement: " + run.pipeline.refinement->failure +
                           "; refined.tum is not written");
  }
  if (dataset.has_ground_truth()) {
    const Trajectory gt = AsReadBackFromTum(run.ground_truth, "groundtruth.tum");
    run.ate_keyframes_m = Ate(gt, run.keyframes, "keyframes.tum", &run.warnings);
    run.ate_trajectory_m = Ate(gt, run.trajectory, "trajectory.tum", &run.warnings);
    if (run.refined()) {
      run.ate_refined_m = Ate(gt, RefinedTrajectory(*run.pipeline.refinement, run.timestamps),
                              "refined.tum", &run.warnings);
    }
    if (run.pipeline.has_estimate) {
      run.consistency_filter = Consistency(run.ground_truth, run.timestamps, run.pipeline.estimate);
    }
    if (run.refined()) {
      run.consistency_refined = Consistency(run.ground_truth, run.timestamps,
                                            SmootherEstimate(run.pipeline.refinement->refined()));
    }
  }
  return run;
}

}  // namespace ieslam
