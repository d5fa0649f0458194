// The options of a run on a dataset (`ieslam run`, RunOnDataset): every stage's, and the one
// registry they are read, reported and written through (core/option_registry.h).
#pragma once

#include <cstdint>
#include <string>

#include "core/dataset.h"
#include "core/json.h"
#include "core/option_registry.h"
#include "core/range_cloud.h"
#include "frontend/dense_map.h"
#include "frontend/rgbd_frame_source.h"
#include "selection/pipeline/localization.h"
#include "selection/pipeline/pipeline.h"

namespace ieslam {

struct RunOptions {
  std::string dataset;  // the directory, as the report names it
  DatasetOptions dataset_options;
  RgbdSourceOptions source;
  PipelineOptions pipeline;
  // With refine: the selected frames' range clouds, aligned in the refinement.
  RangeCloudOptions range_cloud;
  DenseMapOptions map;
  LocalizeOptions localize;  // `ieslam localize` only
  bool build_map = true;
  bool save_map = true;  // OUT/map/map.bin (selection/pipeline/saved_map.h)
  uint32_t seed = 1;     // RANSAC's and the base-frame database's
  int threads = 0;       // 0: every core; 1: the deterministic single-thread mode

  // The run's own options (the top level of a config file: threads, seed, write_map, save_map).
  static const OptionTable<RunOptions>& Table();
  // Every section: dataset, features, matching, lifting, registration, database, source,
  // prefetch, selector, filter, map, ba, depth_alignment, localize and the top level.
  static const OptionRegistry<RunOptions>& Registry();

  bool Check(std::string* why) const;
  // The options as the run uses them: the seed in the front end's options, the thread count
  // in every stage's (prefetch workers, bundle adjustment, alignment). Reports show these.
  RunOptions Resolved() const;
  // Registry().ToJson(Resolved()): report.json's "options".
  Json ToJson() const;
};

// The threads a stage that splits independent work uses for the run's `threads`: every
// core for 0.
int WorkerThreads(int threads);

// Reads a `--config` file (YAML, OpenCV FileStorage syntax: sections such as
// `selector: { buffer: 4 }` and top-level keys such as `threads: 1`; every key optional)
// into *options. Throws ConfigError naming the file and the option for a missing or
// unreadable file, an unknown section or key, a value of the wrong type, or one failing its
// check. Flags given on the command line are applied after it.
void ApplyConfigFile(const std::string& path, RunOptions* options);

// Applies the front-end sections (features, lifting, matching, registration, database,
// source) of `config`, a saved map's options as a config file (`source` names it in errors),
// to *options: a map's descriptors match only frames processed the same way. The mapping run's
// frame range, threads and selection do not carry over.
void ApplyMapFrontEndOptions(const std::string& config, const std::string& source,
                             RunOptions* options);

// The dataset options of `config` (a saved map's options, `source` naming it) over the whole
// sequence: first, last and stride at their defaults, so that frames are numbered as the
// dataset numbers them (FrameInfo::source_index).
DatasetOptions MapDatasetOptions(const std::string& config, const std::string& source);

// `options` as a config file: every settable option with its value and help.
std::string ConfigYaml(const RunOptions& options);

}  // namespace ieslam
