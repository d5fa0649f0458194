#include "selection/pipeline/dataset_run.h"

#include <algorithm>
#include <deque>
#include <filesystem>
#include <functional>
#include <future>

#include <opencv2/core.hpp>

#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "core/error.h"
#include "core/freed_memory.h"
#include "core/stopwatch.h"
#include "frontend/rolling_shutter.h"

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

// What loading one selected frame gives: its map points and range cloud, or why not.
struct LoadedFrame {
  std::string load_error;  // the frame could not be loaded again
  std::vector<DenseMap::Point> points;
  std::optional<RangeCloud> cloud;
  std::string cloud_error;  // the range image gives no cloud
};

LoadedFrame LoadFrame(const Dataset& dataset, int frame, const Eigen::Isometry3d& T_w_c,
                      const RangeCloudOptions& cloud_options, const RangeRays& rays,
                      const RangeRowMotion& row_motion, const DenseMap* map, bool cloud) {
  LoadedFrame out;
  const std::string name = "frame " + std::to_string(frame);
  Frame loaded;
  try {
    loaded = dataset.Load(frame);
  } catch (const DataError& e) {
    out.load_error = e.what();
    return out;
  }
  if (map != nullptr) {
    out.points = map->FramePoints(loaded, dataset.rig(), T_w_c, &rays, row_motion);
  }
  if (!cloud) return out;
  try {
    out.cloud = MakeRangeCloud(loaded.depth, dataset.rig().range, dataset.rig().T_colour_range,
                               cloud_options, name, &rays, row_motion);
  } catch (const DataError& e) {
    out.cloud_error = e.what();
  }
  return out;
}

// What a selected frame's images are for: "the map", "the depth alignment" or both.
std::string FrameUses(bool map, bool alignment) {
  return map && alignment ? "the map and the depth alignment"
         : map            ? "the map"
                          : "the depth alignment";
}

// The velocities of a rolling-shutter rig's `frames` along the estimated trajectory, for their
// range images' rows (frontend/rolling_shutter.h); none for a global shutter. The trajectory is
// taken as trajectory.tum holds it, so that `ieslam refine` finds the same velocities there.
std::map<int, CameraVelocity> RowVelocities(
    const Dataset& dataset, const std::vector<std::optional<Eigen::Isometry3d>>& T_w_c,
    const std::vector<int>& frames, double max_step_s) {
  if (dataset.rig().colour_readout_s == 0.0) return {};
  constexpr double kRowVelocityStampS = 1e-4;  // a frame and its TUM line: microseconds apart
  Trajectory trajectory;
  for (int f = 0; f < static_cast<int>(T_w_c.size()); ++f) {
    if (T_w_c[f]) trajectory.push_back({dataset.info(f).timestamp, *T_w_c[f]});
  }
  std::map<int, double> stamps;
  for (const int f : frames) stamps[f] = dataset.info(f).timestamp;
  return VelocitiesAtStamps(AsReadBackFromTum(trajectory, "trajectory.tum"), stamps, max_step_s,
                            kRowVelocityStampS);
}

// Loads each of `frames` once into the dense map (at its pose in `T_w_c`) and, when `clouds`
// is set, as a range cloud; for a rolling shutter each range row is placed from its own time's
// pose (RowVelocities). A frame that cannot be loaded again, or whose range
// image gives no cloud, is left out with a warning. Stops early, setting *stopped, once `stop`
// (when set) says so. With workers > 0 that many threads load frames (decoding, points, clouds)
// ahead of the caller, who adds them to the map in the given order: the same map as one
// thread gives. Frames `has_images` (when set) says have none (a saved map's keyframes whose
// dataset is gone) are left out.
void LoadSelectedFrames(const Dataset& dataset, const std::function<bool(int)>& has_images,
                        const std::vector<int>& frames,
                        const std::vector<std::optional<Eigen::Isometry3d>>& T_w_c,
                        double velocity_max_step_s, const RangeCloudOptions& cloud_options,
                        int workers, DenseMap* map, RangeClouds* clouds,
                        const std::function<bool()>& stop, bool* stopped,
                        std::vector<std::string>* warnings) {
  const std::string uses = FrameUses(map != nullptr, clouds != nullptr);
  std::vector<int> placed;
  for (const int frame : frames) {
    if (T_w_c[frame] && (!has_images || has_images(frame))) placed.push_back(frame);
  }
  if (placed.empty()) return;
  const std::map<int, CameraVelocity> velocities =
      RowVelocities(dataset, T_w_c, placed, velocity_max_step_s);
  const RangeRays rays(dataset.rig().range);
  const auto load = [&](int frame) {
    const auto velocity = velocities.find(frame);
    const RangeRowMotion row_motion = velocity == velocities.end()
                                          ? RangeRowMotion()
                                          : RangeRowMotionOf(dataset.rig(), velocity->second);
    return LoadFrame(dataset, frame, *T_w_c[frame], cloud_options, rays, row_motion, map,
                     clouds != nullptr);
  };
  // Frames started ahead and not yet added, one per worker (each holds its images and points).
  std::deque<std::future<LoadedFrame>> ahead;
  size_t next = 0;
  for (const int frame : placed) {
    while (workers > 0 && next < placed.size() && ahead.size() < static_cast<size_t>(workers)) {
      ahead.push_back(std::async(std::launch::async, load, placed[next++]));
    }
    if (stop && stop()) {
      *stopped = true;
      for (auto& f : ahead) f.wait();
      return;
    }
    LoadedFrame loaded = workers > 0 ? ahead.front().get() : load(frame);
    if (workers > 0) ahead.pop_front();
    const std::string name = "frame " + std::to_string(frame);
    if (!loaded.load_error.empty()) {
      warnings->push_back(name + " left out of " + uses + ": " + loaded.load_error);
      if (clouds != nullptr) ++clouds->frames_left_out;
      continue;
    }
    if (map != nullptr) map->AddPoints(loaded.points);
    if (clouds == nullptr) continue;
    if (loaded.cloud) {
      clouds->clouds[frame] = std::move(*loaded.cloud);
    } else {
      warnings->push_back(name + " left out of the depth alignment: " + loaded.cloud_error);
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

// The saved map's base frames, as the source handed them over.
struct TakenBaseFrames {
  std::vector<MapBaseFrame> frames;  // one per filter pose, in the filter's order
  bool complete = false;             // false: one was missing, and none was taken
  double seconds = 0.0;
};

// The pipeline's before_finish hook: `next` (the caller's, when set), then the base frame of
// each of the filter's poses moved out of `source` into *taken.
std::function<void(const SelectionResult&, const InformationFilter&)> TakingBaseFrames(
    const std::function<void(const SelectionResult&, const InformationFilter&)>& next,
    const Dataset& dataset, RgbdFrameSource* source, TakenBaseFrames* taken) {
  return [=, &dataset](const SelectionResult& selection, const InformationFilter& filter) {
    if (next) next(selection, filter);
    const auto start = std::chrono::steady_clock::now();
    const std::vector<int>& frames = filter.frame_ids();
    taken->complete = std::all_of(frames.begin(), frames.end(),
                                  [&](int frame) { return source->HasBaseFrame(frame); });
    for (int frame : frames) {
      if (!taken->complete) break;
      auto [processed, ids] = source->TakeBaseFrame(frame);
      MapBaseFrame base;
      base.frame = frame;
      base.timestamp = dataset.info(frame).timestamp;
      base.features = std::move(processed.features);
      base.points = std::move(processed.points);
      base.feature_ids = std::move(ids);
      taken->frames.push_back(std::move(base));
    }
    taken->seconds = SecondsSince(start);
  };
}

// run->saved_map from the base frames, or a warning when they are incomplete; its time and
// the hand-over's in run->map_seconds.
void SaveMap(const Dataset& dataset, const ContinuedDataset* continued, const RunOptions& used,
             TakenBaseFrames taken, RunResult* run) {
  const auto start = std::chrono::steady_clock::now();
  if (taken.complete) {
    const PipelineResult& p = run->pipeline;
    // A later session reads the calibration file again from wherever it runs.
    RunOptions saved = used;
    std::string& calib = saved.dataset_options.calib_file;
    if (!calib.empty()) calib = std::filesystem::absolute(calib).lexically_normal().string();
    run->saved_map = MakeSavedMap(*p.filter, p.estimate, std::move(taken.frames),
                                  p.selection.observations, p.refinement ? &*p.refinement : nullptr,
                                  dataset.rig(), ConfigYaml(saved), used.dataset);
    for (MapKeyframe& k : run->saved_map->keyframes) {
      k.origin = continued != nullptr ? continued->origin(k.frame) : OriginIn(dataset, k.frame);
      const auto& gt = dataset.info(k.frame).T_w_c_gt;
      k.has_ground_truth = gt.has_value();
      if (gt) k.ground_truth = IsometryToPose(*gt);
    }
  } else {
    run->warnings.push_back("a keyframe's base frame is missing: map/map.bin is not written");
  }
  run->map_seconds += taken.seconds + SecondsSince(start);
}

// The ATE of the written trajectories and the stated covariances' consistency against the
// dataset's ground truth (run->ground_truth), timed into run->evaluation_seconds.
void EvaluateAgainstGroundTruth(RunResult* run) {
  const auto ground_truth_start = std::chrono::steady_clock::now();
  const Trajectory gt = AsReadBackFromTum(run->ground_truth, "groundtruth.tum");
  run->ate_keyframes_m = Ate(gt, run->keyframes, "keyframes.tum", &run->warnings);
  run->ate_trajectory_m = Ate(gt, run->trajectory, "trajectory.tum", &run->warnings);
  if (run->refined()) {
    const Refinement& refinement = *run->pipeline.refinement;
    run->ate_refined_m =
        Ate(gt, RefinedTrajectory(refinement, run->timestamps), "refined.tum", &run->warnings);
    if (refinement.corrected) {
      run->ate_refined_uncorrected_m =
          Ate(gt, SolvedTrajectory(refinement.uncorrected_refined(), run->timestamps),
              "the refinement without the depth correction", &run->warnings);
    }
  }
  if (run->pipeline.has_estimate) {
    run->consistency_filter =
        Consistency(run->ground_truth, run->timestamps, run->pipeline.estimate);
  }
  if (run->refined()) {
    run->consistency_refined = Consistency(run->ground_truth, run->timestamps,
                                           SmootherEstimate(run->pipeline.refinement->refined()));
  }
  run->evaluation_seconds += SecondsSince(ground_truth_start);
}

// Going on from `continued`'s map: its keyframes into `source` as base frames, the map's
// frames and file in *run (with a warning where their images would be needed), and what the
// pipeline resumes from.
PipelineResume StartFromMap(const ContinuedDataset& continued, const RunOptions& used,
                            RgbdFrameSource* source, RunResult* run) {
  continued.AddBaseFrames(source);
  run->map_frames = continued.map_frames();
  run->continued_map_file = continued.map().file();
  run->map_load_seconds = continued.map().load_seconds;
  const bool align = used.pipeline.refine && used.pipeline.depth_alignment.rounds > 0;
  const int without = continued.map_frames_without_images();
  if (without > 0 && (used.build_map || align)) {
    run->warnings.push_back(std::to_string(without) + " of the saved map's " +
                            std::to_string(run->map_frames) + " keyframes are left out of " +
                            FrameUses(used.build_map, align) + ": their images are not at hand (" +
                            continued.map_images_missing() + ")");
  }
  return continued.Resume();
}

// The dense map of the selected frames, loaded after the pipeline (which loaded none: no depth
// alignment) on the prefetch workers; a stop after the selection ends it early.
void MapSelectedFrames(const Dataset& dataset, const std::function<bool(int)>& has_images,
                       const RunOptions& used, const PipelineHooks& hooks, RunResult* run) {
  const auto map_start = std::chrono::steady_clock::now();
  const bool selection_interrupted = run->pipeline.selection.interrupted;
  const std::function<bool()> map_stop = [&] {
    return !selection_interrupted && hooks.stop && hooks.stop();
  };
  LoadSelectedFrames(dataset, has_images, run->pipeline.selection.selected, run->pipeline.T_w_c,
                     used.source.velocity_max_step_s, used.range_cloud,
                     used.source.prefetch.workers, &*run->map, nullptr, map_stop,
                     &run->stopped_after_selection, &run->warnings);
  run->map_seconds += SecondsSince(map_start);
}

// RunOnDataset, or with `continued` (which is `dataset`) ContinueMapping.
// The refinement's warnings and failure into the run's, and the calibration its depth
// correction makes.
void FinishRefinement(const Dataset& dataset, RunResult* run) {
  const Refinement& refinement = *run->pipeline.refinement;
  run->warnings.insert(run->warnings.end(), refinement.warnings.begin(), refinement.warnings.end());
  if (!refinement.ok()) {
    run->warnings.push_back("no refinement: " + refinement.failure +
                            "; refined.tum is not written");
    return;
  }
  run->corrected_calibration = CorrectedCalibration(refinement, dataset.rig(), &run->warnings);
}

RunResult Run(const Dataset& dataset, const RunOptions& options, const PipelineHooks& hooks,
              const ContinuedDataset* continued) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  RunResult run;
  run.started = std::chrono::steady_clock::now();
  // OpenCV's TBB back end warns on stderr when asked for more threads than there are cores.
  if (options.threads > 0) cv::setNumThreads(std::min(options.threads, WorkerThreads(0)));
  const RunOptions used = options.Resolved();
  RgbdFrameSource source(dataset, used.source, continued != nullptr ? continued->map_frames() : 0);
  std::function<bool(int)> has_images;
  if (continued != nullptr) has_images = [continued](int f) { return continued->has_images(f); };
  PipelineResume resume;
  if (continued != nullptr) resume = StartFromMap(*continued, used, &source, &run);
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
  // The selected frames are loaded again on as many threads as prefetch the frames.
  const int map_workers = used.source.prefetch.workers;
  // With depth alignment, each selected frame is loaded once for both the map and its cloud.
  bool map_built = false;
  const RangeCloudLoader clouds = [&](const std::vector<int>& frames,
                                      const std::vector<std::optional<Eigen::Isometry3d>>& T_w_c) {
    RangeClouds loaded;
    LoadSelectedFrames(dataset, has_images, frames, T_w_c, used.source.velocity_max_step_s,
                       used.range_cloud, map_workers, run.map ? &*run.map : nullptr, &loaded,
                       loader_stop, &run.stopped_after_selection, &run.warnings);
    map_built = true;
    return loaded;
  };
  // The saved map's base frames, handed over by the source before it lets its frames go.
  TakenBaseFrames taken;
  if (used.save_map) {
    pipeline_hooks.before_finish = TakingBaseFrames(hooks.before_finish, dataset, &source, &taken);
  }
  run.setup_seconds = SecondsSince(run.started);
  run.pipeline =
      RunPipeline(&source, dataset.rig().colour, used.pipeline, pipeline_hooks, clouds,
                  continued != nullptr ? &resume : nullptr, dataset.rig().T_colour_range);
  run.frontend = source.timings();
  if (source.velocities() != nullptr) {
    run.velocity_counts = source.velocities()->counts();
    run.angular_rates_rad_s = source.velocities()->AngularRates();
  }
  if (used.save_map && run.pipeline.has_estimate)
    SaveMap(dataset, continued, used, std::move(taken), &run);
  // Nothing asks the filter for covariances or log dets after the saved map's features: its
  // factor goes back to the system before the map and the outputs allocate theirs.
  if (run.pipeline.has_estimate) {
    run.pipeline.filter->ReleaseFactor();
    ReturnFreedMemory();
  }
  const auto evaluation_start = std::chrono::steady_clock::now();
  CollectTrajectories(dataset, &run);
  run.evaluation_seconds = SecondsSince(evaluation_start);
  if (run.map && !map_built) MapSelectedFrames(dataset, has_images, used, hooks, &run);
  // The frames and points the map's loading freed, before the outputs allocate theirs.
  ReturnFreedMemory();
  // A stop in the refinement or the map, where the selection no longer polls.
  if (!run.pipeline.selection.interrupted && hooks.stop && hooks.stop()) {
    run.stopped_after_selection = true;
  }
  if (run.pipeline.refinement) FinishRefinement(dataset, &run);
  if (dataset.has_ground_truth()) EvaluateAgainstGroundTruth(&run);
  return run;
}

}  // namespace

RunResult RunOnDataset(const Dataset& dataset, const RunOptions& options,
                       const PipelineHooks& hooks) {
  return Run(dataset, options, hooks, nullptr);
}

RunResult ContinueMapping(const ContinuedDataset& dataset, const RunOptions& options,
                          const PipelineHooks& hooks) {
  if (options.pipeline.selector.kind == SelectorKind::kDeadReckoning) {
    throw ConfigError("mapping on from a saved map needs a filter: not with deadreckoning");
  }
  return Run(dataset, options, hooks, &dataset);
}

}  // namespace ieslam
