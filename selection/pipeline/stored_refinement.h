// `ieslam refine` as a library call: the batch refinement of an earlier run from the problem
// it stored (backend/ba_problem_io.h), without the front end and the filter; optionally
// started from the ground truth, and with the run's dataset, its range clouds aligned too.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "backend/ba_problem_io.h"
#include "core/dataset.h"
#include "core/range_cloud.h"
#include "core/trajectory.h"
#include "selection/pipeline/refinement.h"

namespace ieslam {

struct StoredRefinementOptions {
  BundleAdjustmentOptions ba;
  DepthAlignmentOptions depth_alignment;
  RangeCloudOptions range_cloud;
  // A rolling-shutter rig's range rows are placed from their own times' poses, with each
  // keyframe's velocity from the run's trajectory.tum (RgbdSourceOptions's namesake).
  double velocity_max_step_s = 0.1;
  // Start from the ground truth (every frame's pose within 0.02 s) instead of the run's
  // estimate, the features placed from those poses: where the data's own optimum lies.
  bool from_ground_truth = false;

  bool Check(std::string* why) const;
};

struct StoredRefinement {
  StoredBaProblem stored;       // as the run stored it
  Refinement refinement;        // compared with the run's estimate, wherever it started
  Trajectory refined;           // with the frames' timestamps
  bool aligned_clouds = false;  // the dataset's clouds were loaded for the depth alignment
  // Against the ground truth, as `ieslam evaluate` computes them from the files (< 0: none).
  double ate_keyframes_m = -1.0;
  double ate_refined_m = -1.0;
  // With the depth correction applied (Refinement::corrected): the refinement without it.
  double ate_refined_uncorrected_m = -1.0;
  // With the dataset: its calibration with the estimated depth correction
  // (CorrectedCalibration).
  std::optional<Rig> corrected_calibration;
  std::vector<std::string> warnings;
};

// The range clouds of the problem's frames, read from `dataset`: each pose is matched to the
// dataset's frame at its timestamp (within 0.1 ms, as `ieslam evaluate` associates), so that a
// dataset opened without the run's --first/--last/--stride still gives the right frames. A frame
// not found or not readable is left out with a warning. Throws DataError when the dataset's colour
// camera is not the problem's (another calibration) or no frame matches (another dataset). For a
// rolling-shutter rig, `trajectory` (the run's every frame, when given) gives each keyframe's
// velocity from the frames next to it (frontend/rolling_shutter.h), and the keyframe's range
// rows are placed from their own times' poses; without it, or without a velocity, they are not.
RangeClouds LoadRangeCloudsAtTimestamps(const Dataset& dataset, const StoredBaProblem& stored,
                                        const RangeCloudOptions& options,
                                        std::vector<std::string>* warnings,
                                        const Trajectory* trajectory = nullptr,
                                        double velocity_max_step_s = 0.1);

// Refines the run in `run_dir` (its ba_problem.txt; groundtruth.tum and keyframes.tum when
// there, for the ATE and --from-ground-truth; trajectory.tum for a rolling shutter's range
// clouds); `dataset`, when given, is the run's. Throws
// DataError naming the file for a missing or bad stored problem or ground truth, and naming
// ba_problem.txt and why for a refinement that failed (Refinement::failure).
StoredRefinement RefineStoredRun(const std::string& run_dir, const Dataset* dataset,
                                 const StoredRefinementOptions& options);

// report.json of `ieslam refine`: the run and dataset refined (`dataset_dir` empty without
// one), the options as the config sections name them, the ATE, the refinement's summary.
Json StoredRefinementReport(const std::string& run_dir, const std::string& dataset_dir,
                            const StoredRefinementOptions& options, const StoredRefinement& r);

}  // namespace ieslam
