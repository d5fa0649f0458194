// `ieslam refine`: batch refinement of an earlier run without re-running the front end and
// the filter. Reads RUN/ba_problem.txt (written by every `ieslam run` with a filter), bundle-
// adjusts it and writes OUT/refined.tum and OUT/report.json (OUT/refine_report.json when OUT
// is the run's directory: the run's report stays). A failed refinement writes nothing. With
// --dataset (the run's), the selected frames' range images are read again and aligned
// pairwise in the refinement, as `ieslam run --refine` does.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "core/calibration.h"
#include "core/error.h"
#include "core/file_util.h"
#include "selection/pipeline/run_options.h"
#include "selection/pipeline/stored_refinement.h"

namespace ieslam {
namespace {

const std::vector<FlagSpec> kRefineFlags = {
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

StoredRefinementOptions RefineOptionsFromFlags(const Flags& flags, RunOptions* config) {
  if (flags.Has("config")) ApplyConfigFile(flags.Require("config"), config);
  StoredRefinementOptions options;
  options.ba = config->pipeline.ba;
  options.depth_alignment = config->pipeline.depth_alignment;
  options.range_cloud = config->range_cloud;
  options.velocity_max_step_s = config->source.velocity_max_step_s;
  const std::string robust = flags.GetString("robust", BaRobustLossName(options.ba.robust_loss));
  if (!ParseBaRobustLoss(robust, &options.ba.robust_loss)) {
    throw ConfigError("--robust must be none or huber, got '" + robust + "'");
  }
  // As run: pairs align independently (the same constraints for any thread count), so by
  // default they use every core; Ceres' own threads follow --threads only.
  const int threads = flags.GetInt("threads", 0, 1, 256);
  if (threads > 0) options.ba.num_threads = threads;
  options.depth_alignment.num_threads = WorkerThreads(threads);
  options.from_ground_truth = flags.Has("from-ground-truth");
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  if (!flags.Has("dataset") && (flags.Has("format") || flags.Has("calib"))) {
    throw ConfigError("--format and --calib describe --dataset, which is not given");
  }
  return options;
}

}  // namespace

int RefineCommand(const CommandArgs& args) {
  const Flags flags(args, kRefineFlags);
  if (flags.help()) {
    std::cout << FormatHelp(
        "refine", "--run DIR --output OUT [flags]",
        "Bundle-adjusts the keyframes and features of an earlier run\n"
        "(DIR/ba_problem.txt) and writes refined.tum and report.json into OUT\n"
        "(refine_refined.tum and refine_report.json when OUT is DIR: the\n"
        "run's own refined.tum and report.json stay as its report says).\n"
        "With --dataset, the selected frames' range images are aligned\n"
        "pairwise in the refinement (as `ieslam run --refine`), and with\n"
        "ba: {estimate_depth_correction: 1} the dataset's calibration with the\n"
        "estimated depth correction is written as corrected_calib.yaml\n"
        "(refine_corrected_calib.yaml when OUT is DIR); with apply_depth_correction: 1\n"
        "too, the refinement is made again with the estimate applied.",
        kRefineFlags);
    return 0;
  }
  RunOptions config;
  const StoredRefinementOptions options = RefineOptionsFromFlags(flags, &config);
  const std::string run = flags.Require("run");
  const std::string out = flags.Require("output");
  std::unique_ptr<Dataset> dataset;
  // The dataset is read for its clouds, and for its calibration, which a depth correction's
  // estimate needs (the range imager's place) and corrects.
  if (flags.Has("dataset") &&
      (options.depth_alignment.rounds > 0 || options.ba.estimate_depth_correction)) {
    DatasetOptions dataset_options = config.dataset_options;
    dataset_options.format = flags.GetString("format", dataset_options.format);
    dataset_options.calib_file = flags.GetString("calib", dataset_options.calib_file);
    dataset = OpenDataset(flags.Require("dataset"), dataset_options);
    WarnAboutDataset("refine", *dataset);
  }
  PrepareOutputDirectory(out);
  // Into the run's own directory both files go beside the run's, which they must not replace:
  // the run's report describes the run's refined.tum.
  std::error_code ec;
  const bool into_run = std::filesystem::equivalent(run, out, ec);
  const std::string report_name = into_run ? "refine_report.json" : "report.json";
  const std::string refined_name = into_run ? "refine_refined.tum" : "refined.tum";
  const std::string calibration_name =
      into_run ? "refine_corrected_calib.yaml" : "corrected_calib.yaml";
  const StoredRefinement refined = RefineStoredRun(run, dataset.get(), options);
  for (const std::string& warning : refined.warnings) PrintWarning("refine", warning);
  // The report is the set's commit point: gone while the trajectory is replaced, written last.
  RemoveStaleTempFiles(out, {refined_name, report_name, calibration_name});
  // An earlier refinement's calibration goes with its report; without one, a file of that
  // name is the user's. The calibration the dataset was read with is neither removed nor
  // replaced.
  const bool earlier = std::filesystem::exists(JoinPath(out, report_name), ec);
  const bool calibration_in_use =
      dataset != nullptr &&
      std::filesystem::equivalent(JoinPath(out, calibration_name), dataset->calibration_path(), ec);
  for (const std::string& name : {report_name, calibration_name}) {
    if (name == calibration_name && (!earlier || calibration_in_use)) continue;
    std::filesystem::remove(JoinPath(out, name), ec);
    if (ec) throw OutputError("cannot remove " + JoinPath(out, name) + ": " + ec.message());
  }
  WriteTumTrajectory(JoinPath(out, refined_name), refined.refined,
                     "ieslam bundle-adjusted keyframes");
  if (refined.corrected_calibration && calibration_in_use) {
    PrintWarning("refine", JoinPath(out, calibration_name) +
                               " is the calibration the dataset was read with: not replaced");
  } else if (refined.corrected_calibration) {
    WriteCalibration(JoinPath(out, calibration_name), *refined.corrected_calibration);
  }
  const Json report = StoredRefinementReport(run, flags.GetString("dataset", ""), options, refined);
  WriteTextAtomically(JoinPath(out, report_name), report.Dump() + "\n");
  const BundleAdjustmentProblem& problem = refined.stored.problem;
  std::printf("refine: %zu poses, %zu features, %zu observations, %.2f s\n", problem.T_w_c.size(),
              problem.p_w.size(), problem.observations.size(), refined.refinement.seconds);
  if (refined.ate_refined_m >= 0.0) {
    std::printf("refine: ATE RMSE refined keyframes %.4f m\n", refined.ate_refined_m);
    if (refined.ate_refined_uncorrected_m >= 0.0) {
      std::printf("refine: ATE RMSE refined keyframes without the depth correction %.4f m\n",
                  refined.ate_refined_uncorrected_m);
    }
  }
  PrintDepthCorrection("refine", refined.refinement);
  std::printf("refine: results in %s\n", out.c_str());
  return 0;
}

}  // namespace ieslam
