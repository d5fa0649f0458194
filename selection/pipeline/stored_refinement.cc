#include "selection/pipeline/stored_refinement.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <utility>

#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/timestamp_association.h"
#include "core/version.h"
#include "frontend/rolling_shutter.h"
#include "selection/pipeline/run_options.h"

namespace ieslam {
namespace {

bool FileExists(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}

// The problem's initial values, which are the run's filter estimate.
SlamEstimate InitialEstimate(const BundleAdjustmentProblem& problem) {
  SlamEstimate estimate;
  for (const auto& [frame, T_w_c] : problem.T_w_c) estimate.poses[frame] = IsometryToPose(T_w_c);
  estimate.features = problem.p_w;
  return estimate;
}

// Each frame of `stored` associated with the index of its stamp in `stamps` (sorted), as
// `ieslam evaluate` associates: within `max_diff_s`, greedily by time difference.
std::map<int, size_t> FramesAtStamps(const StoredBaProblem& stored,
                                     const std::vector<double>& stamps, double max_diff_s) {
  std::vector<std::pair<double, int>> by_time;  // (timestamp, frame): AssociateStamps sorts
  for (const auto& [frame, stamp] : stored.timestamps) by_time.emplace_back(stamp, frame);
  std::sort(by_time.begin(), by_time.end());
  std::vector<double> frame_stamps;
  for (const auto& [stamp, frame] : by_time) frame_stamps.push_back(stamp);
  std::map<int, size_t> matched;
  for (const StampMatch& m : AssociateStamps(frame_stamps, stamps, 0.0, max_diff_s)) {
    matched[by_time[m.first_index].second] = m.second_index;
  }
  return matched;
}

// The ground-truth pose of every frame of `stored` (within 0.02 s). DataError naming the
// frame and the file when one has none.
std::map<int, Eigen::Isometry3d> GroundTruthPoses(const StoredBaProblem& stored,
                                                  const std::string& gt_path) {
  const Trajectory gt = ReadTumTrajectoryForEvaluation(gt_path);
  std::vector<double> gt_stamps;
  for (const TimedPose& pose : gt) gt_stamps.push_back(pose.timestamp);
  const std::map<int, size_t> matched = FramesAtStamps(stored, gt_stamps, 0.02);
  std::map<int, Eigen::Isometry3d> poses;
  for (const auto& [frame, stamp] : stored.timestamps) {
    const auto it = matched.find(frame);
    if (it == matched.end()) {
      throw DataError("frame " + std::to_string(frame) + " (t = " + std::to_string(stamp) +
                      " s) has no pose in " + gt_path +
                      " within 0.02 s: --from-ground-truth needs one for every frame");
    }
    poses[frame] = gt[it->second].T_w_c;
  }
  return poses;
}

// ATE RMSE against the ground-truth file of the estimate `est` gives (the file `name`, or a
// trajectory as read back from it), as `ieslam evaluate` computes it from the files; -1 with
// a warning when it cannot be computed.
double AteAgainstFile(const std::string& gt_path, const std::function<Trajectory()>& est,
                      const std::string& name, std::vector<std::string>* warnings) {
  try {
    return ComputeAte(ReadTumTrajectoryForEvaluation(gt_path), est(), EvaluationOptions(), gt_path,
                      name)
        .translation.rmse;
  } catch (const DataError& e) {
    warnings->push_back("no ATE for " + name + ": " + e.what());
    return -1.0;
  }
}

void CheckSameCamera(const Dataset& dataset, const PinholeCamera& b) {
  const PinholeCamera& a = dataset.rig().colour;
  if (a.width != b.width || a.height != b.height || std::abs(a.fx - b.fx) > 1e-6 ||
      std::abs(a.fy - b.fy) > 1e-6 || std::abs(a.cx - b.cx) > 1e-6 ||
      std::abs(a.cy - b.cy) > 1e-6) {
    throw DataError(dataset.directory() + ": its colour camera (" + std::to_string(a.fx) + ", " +
                    std::to_string(a.fy) + ", " + std::to_string(a.cx) + ", " +
                    std::to_string(a.cy) + ") is not the run's (" + std::to_string(b.fx) + ", " +
                    std::to_string(b.fy) + ", " + std::to_string(b.cx) + ", " +
                    std::to_string(b.cy) + "): another calibration or dataset");
  }
}

}  // namespace

bool StoredRefinementOptions::Check(std::string* why) const {
  if (!(velocity_max_step_s > 0.0)) {
    if (why != nullptr) *why = "velocity_max_step_s must be positive";
    return false;
  }
  return ba.Check(why) && depth_alignment.Check(why) && range_cloud.Check(why);
}

RangeClouds LoadRangeCloudsAtTimestamps(const Dataset& dataset, const StoredBaProblem& stored,
                                        const RangeCloudOptions& options,
                                        std::vector<std::string>* warnings,
                                        const Trajectory* trajectory, double velocity_max_step_s) {
  constexpr double kSameTimestampS = 1e-4;
  CheckSameCamera(dataset, stored.camera);
  std::vector<double> stamps;
  for (int i = 0; i < dataset.size(); ++i) stamps.push_back(dataset.info(i).timestamp);
  const std::map<int, size_t> matched = FramesAtStamps(stored, stamps, kSameTimestampS);
  const std::map<int, CameraVelocity> velocities =
      dataset.rig().colour_readout_s != 0.0 && trajectory != nullptr
          ? VelocitiesAtStamps(*trajectory, stored.timestamps, velocity_max_step_s, kSameTimestampS)
          : std::map<int, CameraVelocity>();
  RangeClouds loaded;
  const RangeRays rays(dataset.rig().range);
  for (const auto& [frame, T_w_c] : stored.problem.T_w_c) {
    const std::string left_out =
        "frame " + std::to_string(frame) + " left out of the depth alignment: ";
    const auto it = matched.find(frame);
    if (it == matched.end()) {
      warnings->push_back(left_out + "no frame of " + dataset.directory() + " at its timestamp");
      ++loaded.frames_left_out;
      continue;
    }
    try {
      const Frame frame_data = dataset.Load(static_cast<int>(it->second));
      const auto velocity = velocities.find(frame);
      loaded.clouds[frame] = MakeRangeCloud(
          frame_data.depth, dataset.rig().range, dataset.rig().T_colour_range, options,
          "frame " + std::to_string(frame), &rays,
          velocity == velocities.end() ? RangeRowMotion()
                                       : RangeRowMotionOf(dataset.rig(), velocity->second));
    } catch (const DataError& e) {
      warnings->push_back(left_out + e.what());
      ++loaded.frames_left_out;
    }
  }
  if (loaded.clouds.empty() && !stored.problem.T_w_c.empty()) {
    throw DataError(dataset.directory() + ": none of the run's " +
                    std::to_string(stored.problem.T_w_c.size()) +
                    " selected frames found at their timestamps: not the run's dataset");
  }
  return loaded;
}

StoredRefinement RefineStoredRun(const std::string& run_dir, const Dataset* dataset,
                                 const StoredRefinementOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  RequireDirectory(run_dir, "run directory");
  StoredRefinement result;
  result.stored = ReadBaProblem(JoinPath(run_dir, "ba_problem.txt"));
  const StoredBaProblem& stored = result.stored;
  RangeClouds clouds;
  result.aligned_clouds = dataset != nullptr && options.depth_alignment.rounds > 0;
  if (result.aligned_clouds) {
    const std::string frames = JoinPath(run_dir, "trajectory.tum");
    const Trajectory trajectory = FileExists(frames) ? ReadTumTrajectory(frames) : Trajectory();
    clouds = LoadRangeCloudsAtTimestamps(*dataset, stored, options.range_cloud, &result.warnings,
                                         &trajectory, options.velocity_max_step_s);
  }
  const std::string gt = JoinPath(run_dir, "groundtruth.tum");
  const bool has_gt = FileExists(gt);
  BundleAdjustmentProblem started = stored.problem;
  if (options.from_ground_truth) {
    if (!has_gt) throw DataError("--from-ground-truth: " + gt + " not found");
    started = WithPoses(stored.problem, GroundTruthPoses(stored, gt), stored.camera);
  }
  // The filter-versus-smoother comparison is always against the run's own estimate.
  // Without the dataset the range imager is taken to sit at the colour camera (registered).
  result.refinement = Refine(
      started, stored.camera, InitialEstimate(stored.problem), options.ba, options.depth_alignment,
      &clouds, dataset != nullptr ? dataset->rig().T_colour_range : Eigen::Isometry3d::Identity());
  if (!result.refinement.ok()) {
    throw DataError(JoinPath(run_dir, "ba_problem.txt") +
                    ": no refinement: " + result.refinement.failure);
  }
  for (const std::string& warning : result.refinement.warnings) result.warnings.push_back(warning);
  if (dataset != nullptr) {
    result.corrected_calibration =
        CorrectedCalibration(result.refinement, dataset->rig(), &result.warnings);
  }
  result.refined = RefinedTrajectory(result.refinement, stored.timestamps);
  if (has_gt) {
    const std::string keyframes = JoinPath(run_dir, "keyframes.tum");
    if (FileExists(keyframes)) {
      result.ate_keyframes_m = AteAgainstFile(
          gt, [&] { return ReadTumTrajectoryForEvaluation(keyframes); }, keyframes,
          &result.warnings);
    }
    result.ate_refined_m = AteAgainstFile(
        gt, [&] { return AsReadBackFromTum(result.refined, "refined.tum"); }, "refined.tum",
        &result.warnings);
    if (result.refinement.corrected) {
      result.ate_refined_uncorrected_m = AteAgainstFile(
          gt,
          [&] {
            return AsReadBackFromTum(
                SolvedTrajectory(result.refinement.uncorrected_refined(), stored.timestamps),
                "the refinement without the depth correction");
          },
          "the refinement without the depth correction", &result.warnings);
    }
  }
  return result;
}

Json StoredRefinementReport(const std::string& run_dir, const std::string& dataset_dir,
                            const StoredRefinementOptions& options, const StoredRefinement& r) {
  // The options as the run's config sections report them.
  RunOptions used;
  used.pipeline.ba = options.ba;
  used.pipeline.depth_alignment = options.depth_alignment;
  used.range_cloud = options.range_cloud;
  Json sections = RunOptions::Registry().ToJson(used);
  Json report = Json::Object();
  report.Set("version", IeslamVersion())
      .Set("run", run_dir)
      .Set("poses", static_cast<int>(r.stored.problem.T_w_c.size()))
      .Set("features", static_cast<int>(r.stored.problem.p_w.size()))
      .Set("observations", static_cast<int>(r.stored.problem.observations.size()));
  report["options"].Set("ba", sections["ba"]);
  report["options"]["ba"].Set("threads", options.ba.num_threads);
  report["options"].Set("start", options.from_ground_truth ? "ground_truth" : "run");
  if (r.aligned_clouds) {
    report["options"].Set("dataset", dataset_dir);
    report["options"].Set("depth_alignment", sections["depth_alignment"]);
  }
  report["seconds"].Set("ba", r.refinement.seconds);
  if (r.ate_keyframes_m >= 0.0) report["ate_rmse_m"].Set("keyframes", r.ate_keyframes_m);
  if (r.ate_refined_m >= 0.0) report["ate_rmse_m"].Set("refined", r.ate_refined_m);
  if (r.ate_refined_uncorrected_m >= 0.0) {
    report["ate_rmse_m"].Set("refined_without_depth_correction", r.ate_refined_uncorrected_m);
  }
  report.Set("filter_vs_smoother", RefinementToJson(r.refinement));
  return report;
}

}  // namespace ieslam
