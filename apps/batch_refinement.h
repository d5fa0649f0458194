// Batch refinement, shared by `ieslam run --refine` and `ieslam refine`: the bundle
// adjustment of a stored problem, refined.tum, and the filter-versus-smoother comparison.
#pragma once

#include <map>
#include <string>

#include "backend/ba_problem_io.h"
#include "backend/bundle_adjustment.h"
#include "backend/depth_alignment.h"
#include "backend/evaluation/filter_smoother_comparison.h"
#include "core/dataset.h"
#include "core/json.h"
#include "core/range_cloud.h"

namespace ieslam {

struct RefinementOutcome {
  Json comparison;       // report.json's filter_vs_smoother, with the solver's summary as "ba"
  double seconds = 0.0;  // the bundle adjustment's wall time
  double ate_refined_m = -1.0;  // < 0: no ground truth given
};

// The selected frames' range clouds (by frame id) and how to align them.
struct DepthRefinement {
  std::map<int, RangeCloud> clouds;
  int frames_left_out = 0;  // selected frames without a cloud (LoadRangeClouds)
  DepthAlignmentOptions options;
};

// The range clouds of the problem's frames, read again from `dataset`: each pose is matched
// to the dataset's frame with its timestamp (within 0.1 ms), so that a dataset opened
// without the run's --first/--last/--stride still gives the right frames. A frame that is
// not found or cannot be read is left out with a warning on stderr (prefixed by `command`)
// and counted in *left_out; the refinement goes on without it. Throws DataError when the
// dataset's colour camera is not the problem's (another calibration) or no frame matches
// (another dataset).
std::map<int, RangeCloud> LoadRangeClouds(const Dataset& dataset, const StoredBaProblem& stored,
                                          const RangeCloudOptions& options,
                                          const std::string& command, int* left_out);

// Bundle-adjusts `stored` (started from its poses and features) and compares the result with
// `filter_estimate`: the smoother of the filter's own problem, the reference check. With
// clouds in `depth` and depth.options.rounds > 0, the refinement goes on from there with the
// clouds' pairwise alignments (backend/depth_alignment.h), and refined.tum holds that;
// else refined.tum is the bundle adjustment. With a non-empty `gt_path`, the ATE of
// refined.tum against it, as `ieslam evaluate` computes it from the files.
RefinementOutcome RefineToFiles(const StoredBaProblem& stored, const SlamEstimate& filter_estimate,
                                const BundleAdjustmentOptions& options, const std::string& out,
                                const std::string& gt_path, const DepthRefinement* depth = nullptr);

// The options a report records under options.ba (the loss, the rejection gate, iterations).
Json BaOptionsToJson(const BundleAdjustmentOptions& options);
// ... and under options.depth_alignment.
Json DepthAlignmentOptionsToJson(const DepthAlignmentOptions& options,
                                 const RangeCloudOptions& cloud);

// ATE RMSE of a written estimate against written ground truth, exactly as `ieslam evaluate`;
// -1 with a warning on stderr when it cannot be computed (e.g. fewer than 3 matched poses:
// a run that lost track early still writes its report).
double AteOfFiles(const std::string& gt_path, const std::string& est_path);

}  // namespace ieslam
