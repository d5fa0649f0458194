// `ieslam run`: the main job.
#include <cstdio>
#include <iostream>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/config_file.h"
#include "apps/interrupt.h"
#include "apps/run_pipeline.h"
#include "core/error.h"

namespace ieslam {

int RunCommand(const CommandArgs& args) {
  std::vector<FlagSpec> specs = DatasetFlagSpecs();
  const std::vector<FlagSpec> more = {
      {"output", "OUT", "output directory (required)"},
      {"selector", "S", "info (default), all, interval or deadreckoning"},
      {"buffer", "N", "look-ahead buffer of the info selector (default 3)"},
      {"interval", "N", "every N-th frame for --selector interval (default 5)"},
      {"refine", "", "bundle-adjust the selected frames (writes refined.tum)"},
      {"seed", "S", "seed of RANSAC and FLANN (default 1)"},
      {"threads", "N", "1: deterministic single-thread mode (default: all cores)"},
      {"config", "FILE", "YAML with the options of every stage"},
      {"quiet", "", "no progress output"},
      {"verbose", "", "also log every selector decision (candidates, gains, frames added)"}};
  specs.insert(specs.end(), more.begin(), more.end());
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("run", "--dataset DIR --output OUT [flags]",
                            "Runs the SLAM pipeline on a dataset and writes keyframes.tum,\n"
                            "trajectory.tum, groundtruth.tum (with ground truth), map.ply,\n"
                            "selected_frames.txt and report.json into OUT.",
                            specs);
    return 0;
  }
  RunOptions options;
  if (flags.Has("config")) ApplyConfigFile(flags.Require("config"), &options);
  options.dataset = flags.Require("dataset");
  options.output = flags.Require("output");
  options.dataset_options = DatasetOptionsFromFlags(flags);
  const std::string selector = flags.GetString("selector", "info");
  if (flags.Has("selector") && !ParseSelectorKind(selector, &options.selector.kind)) {
    throw ConfigError("--selector must be info, all, interval or deadreckoning, got '" + selector +
                      "'");
  }
  options.selector.buffer_size = flags.GetInt("buffer", options.selector.buffer_size, 1, 100);
  options.selector.interval = flags.GetInt("interval", options.selector.interval, 1, 100000);
  options.seed = static_cast<uint32_t>(flags.GetInt("seed", 1, 0, 2000000000));
  options.threads = flags.GetInt("threads", 0, 0, 256);
  options.quiet = flags.Has("quiet");
  options.verbose = flags.Has("verbose");
  if (options.quiet && options.verbose)
    throw ConfigError("--quiet and --verbose exclude each other");
  options.refine = flags.Has("refine");
  RunSummary summary;
  {
    // The run stops at the next frame boundary and still writes its outputs.
    const StopOnInterrupt interrupt;
    summary = RunPipeline(options, interrupt.Poll());
  }
  std::printf("run: %d of %d frames selected, %zu skipped, state dimension %d\n",
              summary.frames_selected, summary.frames_total, summary.frames_skipped.size(),
              summary.state_dim);
  if (summary.ate_keyframes_m >= 0.0) {
    std::printf("run: ATE RMSE keyframes %.4f m, all frames %.4f m\n", summary.ate_keyframes_m,
                summary.ate_trajectory_m);
    if (options.refine)
      std::printf("run: ATE RMSE refined keyframes %.4f m\n", summary.ate_refined_m);
  }
  std::printf("run: results in %s\n", options.output.c_str());
  if (summary.interrupted) {
    std::fprintf(stderr, "run: interrupted after %d of %d frames; outputs cover those frames\n",
                 summary.frames_processed, summary.frames_total);
    return 130;
  }
  return 0;
}

}  // namespace ieslam
