// The files of `ieslam localize`, each written atomically into OUT: trajectory.tum (every
// localised frame's pose in the map's frame), covariances.txt (each one's 6x6 covariance),
// frames.txt (every frame: placed by the map, by tracking or not, with its inlier counts),
// groundtruth.tum (with ground truth: the dataset's ground truth carried into the map's frame
// through the map's keyframes) and report.json, removed first and written last (the set's
// commit point, as for a run).
#pragma once

#include <string>
#include <vector>

#include "core/dataset.h"
#include "core/json.h"
#include "selection/pipeline/localization.h"
#include "selection/pipeline/run_options.h"
#include "selection/pipeline/saved_map.h"

namespace ieslam {

// What a localisation is judged by: each localised frame with ground truth against the
// ground truth carried into the map's frame (`alignment`), with no alignment of its own.
struct LocalizeEvaluation {
  bool ok = false;
  std::string reason;  // why there is none, when !ok
  int pairs = 0;
  double ate_map_frame_m = 0.0;  // RMSE in the map's frame: the localisation's error
  // RMSE after a Horn alignment of the localised frames alone; with 3 pairs or more.
  bool has_ate_aligned = false;
  double ate_aligned_m = 0.0;
  double median_m = 0.0, max_m = 0.0;
  // Against the stated covariances, with the ground truth through the map's first keyframe
  // (MapFrameAlignment::T_map_gt_origin, when it has ground truth): the share of x, y, z errors
  // inside +-2 sigma, and the mean position NEES (3 dof).
  bool has_consistency = false;
  double inside_2sigma = 0.0;
  double mean_position_nees = 0.0;
};
LocalizeEvaluation EvaluateLocalization(const Dataset& dataset, const LocalizeResult& result,
                                        const MapFrameAlignment& alignment);

// report.json's content. `options` are the options used (resolved).
Json LocalizeReport(const Dataset& dataset, const std::string& map_dir, const SavedMap& map,
                    const RunOptions& options, const LocalizeResult& result,
                    const MapFrameAlignment& alignment, const LocalizeEvaluation& evaluation,
                    double seconds_load_map, double seconds_outputs);

// Writes every file into the existing directory `out` and returns the evaluation the report
// holds. Throws OutputError naming a file that cannot be written or removed.
LocalizeEvaluation WriteLocalizeOutputs(const std::string& out, const Dataset& dataset,
                                        const std::string& map_dir, const SavedMap& map,
                                        const RunOptions& options, const LocalizeResult& result,
                                        const MapFrameAlignment& alignment,
                                        double seconds_load_map);

// Every name WriteLocalizeOutputs writes.
const std::vector<std::string>& LocalizeOutputNames();

}  // namespace ieslam
