// `ieslam localize`: frames placed in a saved map.
#include <cstdio>
#include <iostream>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/interrupt.h"
#include "apps/option_flags.h"
#include "core/error.h"
#include "selection/pipeline/localization.h"
#include "selection/pipeline/localization_outputs.h"
#include "selection/pipeline/run_options.h"
#include "selection/pipeline/saved_map.h"

namespace ieslam {

const std::vector<OptionFlag>& LocalizeOptionFlags() {
  static const std::vector<OptionFlag>* flags = new std::vector<OptionFlag>{
      {"format", "dataset.format"}, {"calib", "dataset.calib"},   {"first", "dataset.first"},
      {"last", "dataset.last"},     {"stride", "dataset.stride"}, {"seed", "seed"},
      {"threads", "threads"}};
  return *flags;
}

namespace {

std::vector<FlagSpec> LocalizeFlagSpecs() {
  std::vector<FlagSpec> specs = {
      {"map", "DIR", "a run's map directory (OUT/map), or the run's OUT"},
      {"dataset", "DIR", "dataset directory (TUM, 7-Scenes or pair layout)"},
      {"output", "OUT", "output directory (required)"},
      {"config", "FILE", "YAML over the map's own options: only the keys you change"},
      {"quiet", "", "no progress output"}};
  const std::vector<FlagSpec> options =
      OptionFlagSpecs(RunOptions::Registry(), LocalizeOptionFlags());
  specs.insert(specs.end(), options.begin(), options.end());
  return specs;
}

}  // namespace

int LocalizeCommand(const CommandArgs& args) {
  const std::vector<FlagSpec> specs = LocalizeFlagSpecs();
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("localize", "--map DIR --dataset DIR --output OUT [flags]",
                            "Places each frame of a dataset in a saved map (ieslam run's\n"
                            "OUT/map) and writes trajectory.tum (map frame), covariances.txt,\n"
                            "frames.txt (how each frame was placed), groundtruth.tum (with\n"
                            "ground truth, in the map frame) and report.json into OUT. The\n"
                            "map is not changed. Frames are matched with the map's own\n"
                            "front-end options; a --config file goes over them, so keep in it\n"
                            "only the keys you change (ieslam options writes every key at its\n"
                            "default).",
                            specs);
    return 0;
  }
  const std::string output = flags.Require("output");
  const bool quiet = flags.Has("quiet");

  const LoadedMap loaded = LoadMap(flags.Require("map"));
  const SavedMap& map = loaded.map;
  const std::string& map_dir = loaded.directory;
  const RunOptions options = RunOptionsFromFlags(flags, LocalizeOptionFlags(), &loaded).Resolved();
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  WarnAboutDataset("localize", *dataset);
  CheckMapCalibration(map, dataset->rig(), map_dir);
  PrepareOutputDirectory(output);

  Progress progress("localize", dataset->size(), quiet);
  LocalizeHooks hooks;
  hooks.progress = [&progress](int done, int localized) {
    progress.Update(done, std::to_string(localized) + " localised");
  };
  int exit_code = 0;
  LocalizeResult result;
  LocalizeEvaluation evaluation;
  {
    const StopOnInterrupt interrupt;
    hooks.stop = interrupt.Poll();
    result = LocalizeDataset(*dataset, map, options.source, options.localize, hooks);
    progress.Finish();
    const MapFrameAlignment alignment = AlignMapToGroundTruth(map, result.refined_poses);
    evaluation = WriteLocalizeOutputs(output, *dataset, map_dir, map, options, result, alignment,
                                      loaded.load_seconds);
    exit_code = result.interrupted ? interrupt.exit_code() : 0;
  }
  const int processed = static_cast<int>(result.frames.size());
  std::printf("localize: %d of %d frames localised in the map of %zu keyframes (%d resumptions)\n",
              result.localized, processed, map.keyframes.size(), result.resumptions);
  if (evaluation.ok) {
    std::printf("localize: ATE RMSE in the map frame %.4f m over %d frames with ground truth\n",
                evaluation.ate_map_frame_m, evaluation.pairs);
  }
  std::printf("localize: results in %s\n", output.c_str());
  if (exit_code != 0) {
    std::fprintf(stderr, "localize: interrupted after %d of %d frames; outputs cover those\n",
                 processed, dataset->size());
  }
  return exit_code;
}

}  // namespace ieslam
