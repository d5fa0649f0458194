// `ieslam run` as a function: dataset -> front end -> selector -> EIF -> output files.
// The command parses flags into RunOptions; tests call RunPipeline directly.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "backend/bundle_adjustment.h"
#include "backend/depth_alignment.h"
#include "backend/information_filter.h"
#include "core/dataset.h"
#include "core/json.h"
#include "frontend/dense_map.h"
#include "frontend/rgbd_frame_source.h"
#include "selection/keyframe_selector.h"

namespace ieslam {

struct RunOptions {
  std::string dataset;
  std::string output;
  DatasetOptions dataset_options;
  RgbdSourceOptions source;
  SelectorOptions selector;
  InformationFilterOptions filter;
  DenseMapOptions map;
  bool refine = false;  // bundle-adjust the selected frames after the filter
  BundleAdjustmentOptions ba;
  // With --refine: the selected frames' range clouds aligned pairwise in the refinement.
  RangeCloudOptions range_cloud;
  DepthAlignmentOptions depth_alignment;
  uint32_t seed = 1;
  int threads = 0;  // 0: OpenCV's default; 1: the deterministic single-thread mode
  bool quiet = false;
  bool verbose = false;  // one log line per selector decision on stderr
  bool write_map = true;

  bool Check(std::string* why) const;
  // The front end's options as the run uses them: `source` with the run's seed (RANSAC's
  // and the matcher's) and its prefetch workers. The report shows these.
  RgbdSourceOptions SourceOptionsUsed() const;
  Json ToJson() const;
};

struct RunSummary {
  bool interrupted = false;
  int frames_processed = 0;
  int frames_total = 0;
  int frames_selected = 0;
  std::vector<std::pair<int, std::string>> frames_skipped;
  int state_dim = 0;
  double ate_keyframes_m = -1.0;  // < 0: no ground truth
  double ate_trajectory_m = -1.0;
  double ate_refined_m = -1.0;
  Json report;
};

// The selector's and the filter's options as reports record them (the config file's
// `selector` and `filter` sections).
Json SelectorOptionsToJson(const SelectorOptions& selector);
Json FilterOptionsToJson(const InformationFilterOptions& filter);

// Runs the whole job and writes every output file into options.output. `stop`, if set, is
// polled between selector decisions: when it returns true the run ends there and the outputs
// of what was processed are written, with "interrupted": true in the report.
RunSummary RunPipeline(const RunOptions& options, const std::function<bool()>& stop = nullptr);

}  // namespace ieslam
