// Pieces every subcommand shares: output directories, dataset flags, progress, reports.
#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include "apps/flags.h"
#include "apps/option_flags.h"
#include "core/dataset.h"
#include "selection/pipeline/refinement.h"
#include "selection/pipeline/run_options.h"
#include "selection/pipeline/saved_map.h"

namespace ieslam {

// Creates OUT (and parents) and checks that a file can be made in it. Throws ConfigError
// naming it when it cannot be created or is a file, OutputError when it is not writable.
void PrepareOutputDirectory(const std::string& path);

// The flags shared by commands that read a dataset, and their parsing.
std::vector<FlagSpec> DatasetFlagSpecs();
DatasetOptions DatasetOptionsFromFlags(const Flags& flags);

// The options of `ieslam run` or `localize`: a saved map's front-end options (when `map` is
// set: its descriptors match only frames processed the same way), then the --config file, then
// --dataset and the flags of `option_flags`. Throws ConfigError for options that do not check.
RunOptions RunOptionsFromFlags(const Flags& flags, const std::vector<OptionFlag>& option_flags,
                               const LoadedMap* map);

// Progress on stderr: a redrawn bar when stderr is a terminal, otherwise a plain log line
// at every 10%. Silent when quiet.
class Progress {
 public:
  Progress(std::string label, int total, bool quiet);
  void Update(int done, const std::string& extra = "");
  void Finish();

 private:
  std::string label_;
  int total_;
  bool quiet_;
  bool terminal_;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_;
};

// "<command>: warning: <text>" on stderr.
void PrintWarning(const std::string& command, const std::string& text);
// The dataset's warnings (Dataset::warnings, a guessed calibration), before it is used.
void WarnAboutDataset(const std::string& command, const Dataset& dataset);

// "<command>: depth correction a b c (sigma ...)" on stdout, when the refinement estimated one.
void PrintDepthCorrection(const std::string& command, const Refinement& refinement);

// One warning per skipped frame (the first few; report.json lists them all), so that a bad
// image in the middle of a long sequence is seen without reading the report.
void WarnAboutSkippedFrames(const std::string& command,
                            const std::vector<std::pair<int, std::string>>& skipped);

}  // namespace ieslam
