#include "apps/app_util.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <system_error>

#include <fcntl.h>
#include <unistd.h>

#include "apps/option_flags.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/stopwatch.h"

namespace ieslam {

void PrepareOutputDirectory(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path)) {
    // A path that cannot be a directory is bad usage, as it always was; a directory that
    // cannot be written is an output error.
    throw ConfigError("cannot create output directory " + path +
                      (ec ? ": " + ec.message() : std::string(": a file is in the way")));
  }
  // A file made and removed: so that an unwritable directory stops the command before its
  // work rather than after it.
  const std::string probe = JoinPath(path, ".ieslam_write_test.tmp." + std::to_string(::getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) {
    throw OutputError("cannot write into output directory " + path + ": " + std::strerror(errno));
  }
  ::close(fd);
  ::unlink(probe.c_str());
}

namespace {

// The dataset options as the flags of a command that reads a dataset set them.
const OptionRegistry<DatasetOptions>& DatasetRegistry() {
  static const OptionRegistry<DatasetOptions>* registry = [] {
    auto* r = new OptionRegistry<DatasetOptions>;
    r->Section<DatasetOptions>("dataset", DatasetOptions::Table(),
                               [](DatasetOptions* o) { return o; });
    return r;
  }();
  return *registry;
}

const std::vector<OptionFlag> kDatasetFlags = {{"format", "dataset.format"},
                                               {"calib", "dataset.calib"},
                                               {"first", "dataset.first"},
                                               {"last", "dataset.last"},
                                               {"stride", "dataset.stride"}};

}  // namespace

std::vector<FlagSpec> DatasetFlagSpecs() {
  std::vector<FlagSpec> specs = {
      {"dataset", "DIR", "dataset directory (TUM, 7-Scenes or pair layout)"}};
  const std::vector<FlagSpec> options = OptionFlagSpecs(DatasetRegistry(), kDatasetFlags);
  specs.insert(specs.end(), options.begin(), options.end());
  return specs;
}

DatasetOptions DatasetOptionsFromFlags(const Flags& flags) {
  DatasetOptions options;
  ApplyOptionFlags(flags, DatasetRegistry(), kDatasetFlags, &options);
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  return options;
}

void PrintWarning(const std::string& command, const std::string& text) {
  std::fprintf(stderr, "%s: warning: %s\n", command.c_str(), text.c_str());
}

void PrintDepthCorrection(const std::string& command, const Refinement& refinement) {
  const DepthCorrectionEstimate& e = refinement.depth_correction;
  if (!refinement.depth_correction_tried || !e.usable) return;
  std::printf(
      "%s: depth correction a %.4f b %.4f c %.4f (sigma %.4f %.4f %.4f), chi-square drop %.0f\n",
      command.c_str(), e.coefficients[0], e.coefficients[1], e.coefficients[2],
      std::sqrt(e.covariance(0, 0)), std::sqrt(e.covariance(1, 1)), std::sqrt(e.covariance(2, 2)),
      2.0 * (e.cost_without - e.cost_with));
}

void WarnAboutDataset(const std::string& command, const Dataset& dataset) {
  for (const std::string& warning : dataset.warnings()) PrintWarning(command, warning);
}

void WarnAboutSkippedFrames(const std::string& command,
                            const std::vector<std::pair<int, std::string>>& skipped) {
  constexpr size_t kShown = 10;
  for (size_t i = 0; i < skipped.size() && i < kShown; ++i) {
    PrintWarning(command,
                 "frame " + std::to_string(skipped[i].first) + " skipped: " + skipped[i].second);
  }
  if (skipped.size() > kShown) {
    PrintWarning(command, std::to_string(skipped.size() - kShown) +
                              " more frames skipped (report.json: frames_skipped)");
  }
}

RunOptions RunOptionsFromFlags(const Flags& flags, const std::vector<OptionFlag>& option_flags,
                               const LoadedMap* map) {
  RunOptions options;
  if (map != nullptr) ApplyMapFrontEndOptions(map->map.options, map->file(), &options);
  if (flags.Has("config")) ApplyConfigFile(flags.Require("config"), &options);
  options.dataset = flags.Require("dataset");
  ApplyOptionFlags(flags, RunOptions::Registry(), option_flags, &options);
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  return options;
}

Progress::Progress(std::string label, int total, bool quiet)
    : label_(std::move(label)),
      total_(total),
      quiet_(quiet),
      terminal_(::isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()) {}

void Progress::Update(int done, const std::string& extra) {
  if (quiet_ || total_ <= 0) return;
  const double seconds = SecondsSince(start_);
  const double rate = seconds > 0.0 ? done / seconds : 0.0;
  const double eta = rate > 0.0 ? (total_ - done) / rate : 0.0;
  char line[256];
  if (terminal_) {
    const int width = 30, filled = width * done / total_;
    std::snprintf(line, sizeof(line), "\r%s [%s%s] %d/%d  %.1f/s  ETA %.0fs  %s", label_.c_str(),
                  std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), done,
                  total_, rate, eta, extra.c_str());
    std::cerr << line << std::flush;
    return;
  }
  const int decile = 10 * done / total_;
  if (decile == last_decile_) return;
  last_decile_ = decile;
  std::snprintf(line, sizeof(line), "%s: %d/%d (%.1f/s, ETA %.0fs) %s", label_.c_str(), done,
                total_, rate, eta, extra.c_str());
  std::cerr << line << "\n";
}

void Progress::Finish() {
  if (!quiet_ && terminal_) std::cerr << "\n";
}

}  // namespace ieslam
