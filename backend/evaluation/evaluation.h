// Trajectory evaluation with the conventions of the TUM RGB-D benchmark tools (Sturm et al.
// 2012): associate.py, evaluate_ate.py and evaluate_rpe.py --fixed_delta. The point of this
// component is that its numbers are comparable with published TUM numbers, so it reproduces
// the reference scripts' choices, quirks included (their nearest-stamp search, their pair
// rules, numpy's median and population std); each quirk is marked "as TUM" where it is coded.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "backend/evaluation/error_stats.h"
#include "core/option_table.h"
#include "core/timestamp_association.h"
#include "core/trajectory.h"

namespace ieslam {

// What `delta` of the relative pose error counts (evaluate_rpe.py --delta_unit s|f).
enum class DeltaUnit { kSeconds, kFrames };

// "s"/"seconds" or "f"/"frames"; false for anything else.
bool ParseDeltaUnit(const std::string& text, DeltaUnit* unit);
// "s" or "f", the spelling of evaluate_rpe.py and of the CLI.
std::string DeltaUnitName(DeltaUnit unit);

struct EvaluationOptions {
  // Association window: pairs with |t_gt - (t_est + offset_s)| < max_diff_s (ATE only;
  // the RPE, as TUM, looks for the nearest ground-truth stamp instead).
  double max_diff_s = 0.02;
  // Added to the estimate's timestamps (both ATE and RPE).
  double offset_s = 0.0;
  // Multiplies the estimate's translations (ATE positions, RPE relative translations).
  double scale = 1.0;
  // RPE step between the two poses of a pair, in `delta_unit`.
  double delta = 1.0;
  DeltaUnit delta_unit = DeltaUnit::kSeconds;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<EvaluationOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

// evaluate_rpe.py's find_closest_index: a binary search over the sorted `list` that keeps the
// closest element it visits (the first visited wins a tie). CHECK-fails on an empty list.
std::size_t FindClosestIndex(const std::vector<double>& list, double value);

// Horn's closed-form rigid alignment (evaluate_ate.py `align`): the rotation and translation,
// no scale, minimising sum |p_gt - (R p_est + t)|^2, with the SVD determinant fix so that R is
// a rotation. Returns T_gt_est. CHECK-fails unless both lists have the same size >= 3.
Eigen::Isometry3d AlignHorn(const std::vector<Eigen::Vector3d>& p_est,
                            const std::vector<Eigen::Vector3d>& p_gt);

// One associated ATE pair, for plots.
struct AtePair {
  double gt_timestamp = 0.0;
  double est_timestamp = 0.0;
  Eigen::Vector3d p_gt = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_est_aligned = Eigen::Vector3d::Zero();  // T_gt_est * (scale * p_est)
  double error = 0.0;                                       // |p_gt - p_est_aligned|, metres
};

struct AteResult {
  ErrorStats translation;  // metres; translation.count is the number of pairs
  Eigen::Isometry3d T_gt_est = Eigen::Isometry3d::Identity();  // Horn alignment
  std::vector<AtePair> pairs;                                  // sorted by gt_timestamp
};

// One RPE pair, as evaluate_rpe.py --save writes it.
struct RpePair {
  double est_timestamp_0 = 0.0;
  double est_timestamp_1 = 0.0;
  double gt_timestamp_0 = 0.0;
  double gt_timestamp_1 = 0.0;
  double translation_error = 0.0;   // metres
  double rotation_error_rad = 0.0;  // radians, as the script keeps them
};

struct RpeResult {
  ErrorStats translation;  // metres; translation.count is the number of pairs
  ErrorStats rotation;     // degrees
  std::vector<RpePair> pairs;
};

struct EvaluationResult {
  EvaluationOptions options;  // the options used, for the report
  AteResult ate;
  RpeResult rpe;
  // Why the ATE / the RPE could not be computed (ComputeAte's / ComputeRpe's DataError), or ""
  // when it was and `ate` / `rpe` hold it. A short trajectory can have an ATE but no pair
  // `delta` apart.
  std::string ate_unavailable;
  std::string rpe_unavailable;
  // The whole estimate (every stamp, not only associated ones) scaled and mapped into the
  // ground-truth frame by ate.T_gt_est, with est timestamps + offset_s; for plots. Empty
  // without an ATE.
  Trajectory aligned_estimate;
  // Things a user should hear about that did not stop the evaluation (repeated stamps).
  std::vector<std::string> warnings;
};

// Absolute trajectory error. `gt_name` / `est_name` (usually the file paths) name the inputs
// in errors. Throws ConfigError for options failing Check(), DataError for an empty input or
// fewer than 3 associated pairs (the alignment is undefined).
AteResult ComputeAte(const Trajectory& gt, const Trajectory& est, const EvaluationOptions& options,
                     const std::string& gt_name = "ground truth",
                     const std::string& est_name = "estimate");

// Relative pose error with fixed delta (evaluate_rpe.py --fixed_delta). Every pair is used:
// the script randomly sub-samples only beyond --max_pairs (10000) pairs, which this does not
// (it equals the script with --max_pairs 0). Throws as ComputeAte, and DataError when fewer
// than 2 pairs survive (the script's own limit).
RpeResult ComputeRpe(const Trajectory& gt, const Trajectory& est, const EvaluationOptions& options,
                     const std::string& gt_name = "ground truth",
                     const std::string& est_name = "estimate");

// ATE, RPE and the aligned estimate: each of the ATE and the RPE that can be computed, the
// other's reason in *_unavailable. Throws ConfigError for options failing Check(), DataError
// (both reasons) when neither can be computed. The trajectories' files are read, and the
// result written, by backend/evaluation/evaluation_io.h.
EvaluationResult EvaluateTrajectories(const Trajectory& gt, const Trajectory& est,
                                      const EvaluationOptions& options,
                                      const std::string& gt_name = "ground truth",
                                      const std::string& est_name = "estimate");

}  // namespace ieslam
