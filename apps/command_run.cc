// `ieslam run`: the main job.
#include <cstdio>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/interrupt.h"
#include "apps/option_flags.h"
#include "core/error.h"
#include "selection/pipeline/dataset_run.h"
#include "selection/pipeline/run_outputs.h"
#include "selection/pipeline/run_report.h"

namespace ieslam {

// Flags that set one option each; the others (dataset, output, config, quiet, verbose) are
// the command's own.
const std::vector<OptionFlag>& RunOptionFlags() {
  static const std::vector<OptionFlag>* flags =
      new std::vector<OptionFlag>{{"format", "dataset.format"},  {"calib", "dataset.calib"},
                                  {"first", "dataset.first"},    {"last", "dataset.last"},
                                  {"stride", "dataset.stride"},  {"selector", "selector.kind"},
                                  {"buffer", "selector.buffer"}, {"interval", "selector.interval"},
                                  {"refine", "refine"},          {"seed", "seed"},
                                  {"threads", "threads"}};
  return *flags;
}

namespace {

std::vector<FlagSpec> RunFlagSpecs() {
  std::vector<FlagSpec> specs = {
      {"dataset", "DIR", "dataset directory (TUM, 7-Scenes or pair layout)"},
      {"output", "OUT", "output directory (required)"},
      {"config", "FILE", "YAML with the options of every stage (ieslam options writes one)"},
      {"map", "DIR", "go on mapping from a saved map (a run's OUT/map, or its OUT)"},
      {"quiet", "", "no progress output"},
      {"verbose", "", "also log every selector decision (candidates, gains, frames added)"}};
  const std::vector<FlagSpec> options = OptionFlagSpecs(RunOptions::Registry(), RunOptionFlags());
  specs.insert(specs.end(), options.begin(), options.end());
  return specs;
}

void PrintSummary(const Dataset& dataset, const RunResult& run, const std::string& output) {
  const PipelineResult& p = run.pipeline;
  std::printf("run: %zu of %d frames selected, %zu skipped, state dimension %d\n",
              p.selection.selected.size(), dataset.size(), run.frames_skipped.size(),
              p.filter->state_dim());
  if (run.ate_keyframes_m >= 0.0) {
    std::printf("run: ATE RMSE keyframes %.4f m, all frames %.4f m\n", run.ate_keyframes_m,
                run.ate_trajectory_m);
    if (run.refined()) {
      std::printf("run: ATE RMSE refined keyframes %.4f m\n", run.ate_refined_m);
      if (run.ate_refined_uncorrected_m >= 0.0) {
        std::printf("run: ATE RMSE refined keyframes without the depth correction %.4f m\n",
                    run.ate_refined_uncorrected_m);
      }
    }
  }
  if (run.refined()) PrintDepthCorrection("run", *p.refinement);
  std::printf("run: results in %s\n", output.c_str());
}

}  // namespace

int RunCommand(const CommandArgs& args) {
  const std::vector<FlagSpec> specs = RunFlagSpecs();
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("run", "--dataset DIR --output OUT [flags]",
                            "Runs the SLAM pipeline on a dataset and writes keyframes.tum,\n"
                            "trajectory.tum, groundtruth.tum (with ground truth), map.ply,\n"
                            "map/map.bin (the map, for later sessions), selected_frames.txt\n"
                            "and report.json into OUT. With --map, mapping goes on from a saved\n"
                            "map: its keyframes are frames 0..K-1 of the outputs, the dataset's\n"
                            "frames follow, and OUT/map holds the map of both sessions; the\n"
                            "map's front-end options are used, with a --config file over them.",
                            specs);
    return 0;
  }
  const std::string output = flags.Require("output");
  const bool quiet = flags.Has("quiet"), verbose = flags.Has("verbose");
  if (quiet && verbose) throw ConfigError("--quiet and --verbose exclude each other");
  std::optional<LoadedMap> map;
  if (flags.Has("map")) map = LoadMap(flags.Require("map"));
  const RunOptions options = RunOptionsFromFlags(flags, RunOptionFlags(), map ? &*map : nullptr);
  const auto opened = OpenDataset(options.dataset, options.dataset_options);
  std::unique_ptr<ContinuedDataset> continued;
  if (map) continued = std::make_unique<ContinuedDataset>(*map, *opened, options.dataset_options);
  const Dataset* dataset = continued ? continued.get() : opened.get();
  WarnAboutDataset("run", *dataset);
  PrepareOutputDirectory(output);
  Progress progress("run", dataset->size(), quiet);
  PipelineHooks hooks;
  hooks.progress = [&progress](int done, int selected) {
    progress.Update(done, std::to_string(selected) + " selected");
  };
  if (verbose) {
    hooks.on_decision = [dataset](const SelectionDecision& d) {
      std::fprintf(stderr, "%s\n", DescribeDecision(d, *dataset).c_str());
    };
  }
  RunResult run;
  int exit_code = 0;
  {
    // The run stops at the next frame boundary (or in its refinement or map) and still
    // writes its outputs.
    const StopOnInterrupt interrupt;
    hooks.stop = interrupt.Poll();
    run = continued ? ContinueMapping(*continued, options, hooks)
                    : RunOnDataset(*dataset, options, hooks);
    progress.Finish();
    WarnAboutSkippedFrames("run", run.frames_skipped);
    for (const std::string& warning : run.warnings) PrintWarning("run", warning);
    // The exit code says what the report says: a signal after report.json's last look at
    // the flag finds every output written.
    bool stopped_while_writing = false;
    const std::function<bool()> poll = interrupt.Poll();
    WriteRunOutputs(output, *dataset, options, run, [&] { return stopped_while_writing = poll(); });
    exit_code = run.interrupted() || stopped_while_writing ? interrupt.exit_code() : 0;
  }
  PrintSummary(*dataset, run, output);
  if (exit_code != 0) {
    std::fprintf(stderr, "run: interrupted after %d of %d frames; outputs cover those frames\n",
                 run.frames_processed(), dataset->size());
  }
  return exit_code;
}

}  // namespace ieslam
