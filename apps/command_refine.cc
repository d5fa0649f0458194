// `ieslam refine`: batch refinement of an earlier run without re-running the front end and
// the filter. Reads RUN/ba_problem.txt (written by every `ieslam run` with a filter), bundle-
// adjusts it and writes OUT/refined.tum and OUT/report.json.
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "apps/app_util.h"
#include "apps/batch_refinement.h"
#include "apps/commands.h"
#include "apps/config_file.h"
#include "apps/run_pipeline.h"
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
      {"config", "FILE", "YAML; its ba section sets the solver's options"},
      {"threads", "N", "1: deterministic single-thread mode (default: 1)"}};
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("refine", "--run DIR --output OUT [flags]",
                            "Bundle-adjusts the keyframes and features of an earlier run\n"
                            "(DIR/ba_problem.txt) and writes refined.tum and report.json into OUT.",
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
  ba.num_threads = flags.GetInt("threads", 1, 1, 256);
  std::string why;
  if (!ba.Check(&why)) throw ConfigError(why);

  const std::string run = flags.Require("run");
  const std::string out = flags.Require("output");
  RequireDirectory(run, "run directory");
  const StoredBaProblem stored = ReadBaProblem(JoinPath(run, "ba_problem.txt"));
  PrepareOutputDirectory(out);
  const std::string gt = JoinPath(run, "groundtruth.tum");
  const bool has_gt = FileExists(gt);
  const RefinementOutcome refined =
      RefineToFiles(stored, InitialEstimate(stored.problem), ba, out, has_gt ? gt : std::string());

  Json report = Json::Object();
  report.Set("version", IESLAM_VERSION)
      .Set("run", run)
      .Set("poses", static_cast<int>(stored.problem.T_w_c.size()))
      .Set("features", static_cast<int>(stored.problem.p_w.size()))
      .Set("observations", static_cast<int>(stored.problem.observations.size()));
  report["options"].Set("ba", BaOptionsToJson(ba));
  report["options"]["ba"].Set("threads", ba.num_threads);
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
  if (refined.ate_refined_m >= 0.0) std::printf("refine: ATE RMSE refined keyframes %.4f m\n", refined.ate_refined_m);
  std::printf("refine: results in %s\n", out.c_str());
  return 0;
}

}  // namespace ieslam
