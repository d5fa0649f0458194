// Batch refinement, shared by `ieslam run --refine` and `ieslam refine`: the bundle
// adjustment of a stored problem, refined.tum, and the filter-versus-smoother comparison.
#pragma once

#include <string>

#include "backend/ba_problem_io.h"
#include "backend/bundle_adjustment.h"
#include "backend/filter_smoother_comparison.h"
#include "core/json.h"

namespace ieslam {

struct RefinementOutcome {
  Json comparison;        // report.json's filter_vs_smoother, with the solver's summary as "ba"
  double seconds = 0.0;   // the bundle adjustment's wall time
  double ate_refined_m = -1.0;  // < 0: no ground truth given
};

// Bundle-adjusts `stored` (started from its poses and features), writes OUT/refined.tum and
// compares the result with `filter_estimate`. With a non-empty `gt_path`, the ATE of
// refined.tum against it, as `ieslam evaluate` computes it from the files.
RefinementOutcome RefineToFiles(const StoredBaProblem& stored, const SlamEstimate& filter_estimate,
                                const BundleAdjustmentOptions& options, const std::string& out,
                                const std::string& gt_path);

// The options a report records under options.ba (the loss, the rejection gate, iterations).
Json BaOptionsToJson(const BundleAdjustmentOptions& options);

// ATE RMSE of a written estimate against written ground truth, exactly as `ieslam evaluate`;
// -1 with a warning on stderr when it cannot be computed (e.g. fewer than 3 matched poses:
// a run that lost track early still writes its report).
double AteOfFiles(const std::string& gt_path, const std::string& est_path);

}  // namespace ieslam
