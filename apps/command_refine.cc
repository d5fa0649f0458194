// `ieslam refine`: batch refinement of an earlier run without re-running the front end and
// the filter. Reads RUN/ba_problem.txt (written by every `ieslam run` with a filter), bundle-
// adjusts it and writes OUT/refined.tum and OUT/report.json. With --dataset (the run's),
// the selected frames' range images are read again and aligned pairwise in the refinement,
// as `ieslam run --refine` does.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <thread>

#include "apps/app_util.h"
#include "apps/batch_refinement.h"
#include "apps/commands.h"
#include "apps/config_file.h"
#include "apps/run_pipeline.h"
#include "backend/evaluation/evaluation.h"
#include "core/error.h"
#include "core/file_util.h"

namespace ieslam {
namespace {

// The problem's initial values, which are the filter's estimate of the run.
SlamEstimate InitialEstimate(const BundleAdjustmentProblem& problem) {
  SlamEstimate estimate;
  for (const auto& [frame, T_w_c] : problem.T_w_c) estimate.poses[frame] = IsometryToPose(T_w_c);
  estimate.features = problem.p_w;
  return estimate;
}

// The run's ground-truth pose of every frame of `stored`, matched by timestamp as
// `ieslam evaluate` associates (within 0.02 s). DataError naming the frame and the file when
// one has none.
std::map<int, Eigen::Isometry3d> GroundTruthPoses(const StoredBaProblem& stored,
                                                  const std::string& gt_path) {
  const Trajectory gt = ReadTumTrajectoryForEvaluation(gt_path);
  std::vector<double> gt_stamps;
  for (const TimedPose& pose : gt) gt_stamps.push_back(pose.timestamp);
  // AssociateStamps takes stamps in time order.
  std::vector<std::pair<double, int>> by_time;  // (timestamp, frame)
  for (const auto& [frame, stamp] : stored.timestamps) by_time.emplace_back(stamp, frame);
  std::sort(by_time.begin(), by_time.end());
  std::vector<double> frame_stamps;
  for (const auto& [stamp, frame] : by_time) frame_stamps.push_back(stamp);
  std::map<int, Eigen::Isometry3d> poses;
  for (const StampMatch& m : AssociateStamps(frame_stamps, gt_stamps, 0.0, 0.02)) {
    poses[by_time[m.first_index].second] = gt[m.second_index].T_w_c;
  }
  for (const auto& [frame, stamp] : stored.timestamps) {
    if (poses.count(frame) == 0) {
      throw DataError("frame " + std::to_string(frame) + " (t = " + std::to_string(stamp) +
                      " s) has no pose in " + gt_path +
                      " within 0.02 s: --from-ground-truth needs one for every frame");
    }
  }
  return poses;
}

bool FileExists(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}

}  // namespace

int RefineCommand(const CommandArgs& args) {
  const std::vector<FlagSpec> specs = {
      {"run", "DIR", "output directory of an earlier `ieslam run` (required)"},
      {"output", "OUT", "output directory (required; may be DIR itself)"},
      {"robust", "L", "none (default) or huber: loss on the whitened residuals"},
      {"dataset", "DIR", "the run's dataset: align the selected frames' range images too"},
      {"format", "F", "with --dataset: auto (default), tum, 7scenes or pair"},
      {"calib", "FILE", "with --dataset: calibration file (default: the format's)"},
      {"config", "FILE", "YAML; its ba and depth_alignment sections set the options"},
      {"from-ground-truth", "",
       "start from DIR/groundtruth.tum instead of the run's estimate "
       "(features placed from those poses): where the data's own "
       "optimum lies against the ground truth"},
      {"threads", "N",
       "threads of the alignment and the bundle adjustment; 1: the deterministic "
       "single-thread mode (default: the pairs aligned on all cores, the bundle "
       "adjustment on one, which gives the same result as 1)"}};
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp(
        "refine", "--run DIR --output OUT [flags]",
        "Bundle-adjusts the keyframes and features of an earlier run\n"
        "(DIR/ba_problem.txt) and writes refined.tum and report.json into OUT.\n"
        "With --dataset, the selected frames' range images are aligned\n"
        "pairwise in the refinement (as `ieslam run --refine`).",
        specs);
    return 0;
  }
  RunOptions options;
  if (flags.Has("config")) ApplyConfigFile(flags.Require("config"), &options);
  BundleAdjustmentOptions ba = options.ba;
  const std::string robust = flags.GetString("robust", BaRobustLossName(ba.robust_loss));
  if (!ParseBaRobustLoss(robust, &ba.robust_loss)) {
    throw ConfigError("--robust must be none or huber, got '" + robust + "'");
  }
  // As run: pairs align independently (the same constraints for any thread count), so by
  // default they use every core; Ceres' own threads follow --threads only.
  const int threads = flags.GetInt("threads", 0, 1, 256);
  if (threads > 0) ba.num_threads = threads;
  std::string why;
  if (!ba.Check(&why)) throw ConfigError(why);

  const std::string run = flags.Require("run");
  const std::string out = flags.Require("output");
  RequireDirectory(run, "run directory");
  const StoredBaProblem stored = ReadBaProblem(JoinPath(run, "ba_problem.txt"));
  DepthRefinement depth;
  depth.options = options.depth_alignment;
  depth.options.num_threads =
      threads > 0 ? threads : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  if (!flags.Has("dataset") && (flags.Has("format") || flags.Has("calib"))) {
    throw ConfigError("--format and --calib describe --dataset, which is not given");
  }
  if (flags.Has("dataset") && depth.options.rounds > 0) {
    DatasetOptions dataset_options = options.dataset_options;
    dataset_options.format = flags.GetString("format", dataset_options.format);
    dataset_options.calib_file = flags.GetString("calib", dataset_options.calib_file);
    const auto dataset = OpenDataset(flags.Require("dataset"), dataset_options);
    depth.clouds =
        LoadRangeClouds(*dataset, stored, options.range_cloud, "refine", &depth.frames_left_out);
  }
  PrepareOutputDirectory(out);
  const std::string gt = JoinPath(run, "groundtruth.tum");
  const bool has_gt = FileExists(gt);
  // The filter-versus-smoother comparison is always against the run's own estimate.
  const SlamEstimate run_estimate = InitialEstimate(stored.problem);
  StoredBaProblem started = stored;
  if (flags.Has("from-ground-truth")) {
    if (!has_gt) throw DataError("--from-ground-truth: " + gt + " not found");
    started.problem = WithPoses(stored.problem, GroundTruthPoses(stored, gt), stored.camera);
  }
  const RefinementOutcome refined =
      RefineToFiles(started, run_estimate, ba, out, has_gt ? gt : std::string(), &depth);

  Json report = Json::Object();
  report.Set("version", IESLAM_VERSION)
      .Set("run", run)
      .Set("poses", static_cast<int>(stored.problem.T_w_c.size()))
      .Set("features", static_cast<int>(stored.problem.p_w.size()))
      .Set("observations", static_cast<int>(stored.problem.observations.size()));
  report["options"].Set("ba", BaOptionsToJson(ba));
  report["options"]["ba"].Set("threads", ba.num_threads);
  report["options"].Set("start", flags.Has("from-ground-truth") ? "ground_truth" : "run");
  if (!depth.clouds.empty()) {
    report["options"].Set("dataset", flags.GetString("dataset", ""));
    report["options"].Set("depth_alignment",
                          DepthAlignmentOptionsToJson(depth.options, options.range_cloud));
  }
  report["seconds"].Set("ba", refined.seconds);
  const std::string keyframes = JoinPath(run, "keyframes.tum");
  if (has_gt) {
    const double keyframes_ate = FileExists(keyframes) ? AteOfFiles(gt, keyframes) : -1.0;
    if (keyframes_ate >= 0.0) report["ate_rmse_m"].Set("keyframes", keyframes_ate);
    if (refined.ate_refined_m >= 0.0) report["ate_rmse_m"].Set("refined", refined.ate_refined_m);
  }
  report.Set("filter_vs_smoother", refined.comparison);
  WriteTextAtomically(JoinPath(out, "report.json"), report.Dump() + "\n");

  std::printf("refine: %zu poses, %zu features, %zu observations, %.2f s\n",
              stored.problem.T_w_c.size(), stored.problem.p_w.size(),
              stored.problem.observations.size(), refined.seconds);
  if (refined.ate_refined_m >= 0.0)
    std::printf("refine: ATE RMSE refined keyframes %.4f m\n", refined.ate_refined_m);
  std::printf("refine: results in %s\n", out.c_str());
  return 0;
}

}  // namespace ieslam
