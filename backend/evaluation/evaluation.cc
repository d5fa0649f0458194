#include "backend/evaluation/evaluation.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <unordered_set>
#include <utility>

#include <glog/logging.h>
#include <Eigen/SVD>

#include "core/error.h"

namespace ieslam {
namespace {

constexpr double kRadToDeg = 180.0 / EIGEN_PI;

std::vector<double> Stamps(const Trajectory& trajectory) {
  std::vector<double> stamps;
  stamps.reserve(trajectory.size());
  for (const TimedPose& pose : trajectory) stamps.push_back(pose.timestamp);
  return stamps;
}

// The binary searches need strictly increasing stamps; both readers promise them, but a
// hand-built trajectory might not, and that is bad data, not a bug.
void RequireUsable(const Trajectory& trajectory, std::size_t min_size, const std::string& name) {
  if (trajectory.size() < min_size) {
    throw DataError(name + ": " + std::to_string(trajectory.size()) +
                    " poses, the evaluation needs at least " + std::to_string(min_size));
  }
  for (std::size_t i = 1; i < trajectory.size(); ++i) {
    if (!(trajectory[i].timestamp > trajectory[i - 1].timestamp)) {
      std::ostringstream s;
      s.precision(6);
      s << std::fixed << name << ": timestamps must increase strictly, pose " << i << " has "
        << trajectory[i].timestamp << " after " << trajectory[i - 1].timestamp;
      throw DataError(s.str());
    }
  }
}

void RequireValidOptions(const EvaluationOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("evaluation options: " + why);
}

// The pose with its translation multiplied by `scale` (evaluate_rpe.py `scale`).
Eigen::Isometry3d ScaleTranslation(const Eigen::Isometry3d& T, double scale) {
  Eigen::Isometry3d scaled = T;
  scaled.translation() *= scale;
  return scaled;
}

// evaluate_rpe.py `compute_angle`: the rotation angle from the trace. arccos is poor near 0,
// but using a better formula would move the numbers away from TUM's.
double RotationAngle(const Eigen::Matrix3d& R) {
  return std::acos(std::min(1.0, std::max(-1.0, (R.trace() - 1.0) / 2.0)));
}

}  // namespace

bool ParseDeltaUnit(const std::string& text, DeltaUnit* unit) {
  CHECK(unit != nullptr);
  if (text == "s" || text == "seconds") {
    *unit = DeltaUnit::kSeconds;
  } else if (text == "f" || text == "frames") {
    *unit = DeltaUnit::kFrames;
  } else {
    return false;
  }
  return true;
}

std::string DeltaUnitName(DeltaUnit unit) { return unit == DeltaUnit::kSeconds ? "s" : "f"; }

const OptionTable<EvaluationOptions>& EvaluationOptions::Table() {
  static const OptionTable<EvaluationOptions>* table = [] {
    using O = EvaluationOptions;
    auto* t = new OptionTable<O>;
    t->Double("max_diff_s", &O::max_diff_s, "association window in seconds").Above(0.0);
    t->Double("offset_s", &O::offset_s, "added to the estimate's timestamps");
    t->Double("scale", &O::scale, "multiplies the estimate's translations").Above(0.0);
    t->Double("delta", &O::delta, "RPE step").Above(0.0);
    t->Enum("delta_unit", &O::delta_unit, ParseDeltaUnit, DeltaUnitName, "s|f",
            "RPE step in seconds or frames");
    return t;
  }();
  return *table;
}

std::size_t FindClosestIndex(const std::vector<double>& list, double value) {
  CHECK(!list.empty());
  // As TUM: this is not std::lower_bound plus a neighbour check; on ties the element visited
  // first by the bisection wins, which decides pairs in the RPE.
  std::size_t beginning = 0;
  std::size_t end = list.size();
  std::size_t best = 0;
  double difference = std::abs(list[0] - value);
  while (beginning < end) {
    const std::size_t middle = (beginning + end) / 2;
    if (std::abs(list[middle] - value) < difference) {
      difference = std::abs(list[middle] - value);
      best = middle;
    }
    if (value == list[middle]) return middle;
    if (list[middle] > value) {
      end = middle;
    } else {
      beginning = middle + 1;
    }
  }
  return best;
}

Eigen::Isometry3d AlignHorn(const std::vector<Eigen::Vector3d>& p_est,
                            const std::vector<Eigen::Vector3d>& p_gt) {
  CHECK_EQ(p_est.size(), p_gt.size());
  CHECK_GE(p_est.size(), 3u);
  const double n = static_cast<double>(p_est.size());
  Eigen::Vector3d mean_est = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_gt = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < p_est.size(); ++i) {
    mean_est += p_est[i];
    mean_gt += p_gt[i];
  }
  mean_est /= n;
  mean_gt /= n;
  // W = sum (p_est - mean)(p_gt - mean)^T; evaluate_ate.py decomposes W^T = U S V^T and takes
  // R = U diag(1, 1, det) V^T.
  Eigen::Matrix3d W = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < p_est.size(); ++i) {
    W += (p_est[i] - mean_est) * (p_gt[i] - mean_gt).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(W.transpose(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (U.determinant() * V.determinant() < 0.0) S(2, 2) = -1.0;  // a reflection otherwise
  Eigen::Isometry3d T_gt_est = Eigen::Isometry3d::Identity();
  T_gt_est.linear() = U * S * V.transpose();
  T_gt_est.translation() = mean_gt - T_gt_est.linear() * mean_est;
  return T_gt_est;
}

AteResult ComputeAte(const Trajectory& gt, const Trajectory& est, const EvaluationOptions& options,
                     const std::string& gt_name, const std::string& est_name) {
  RequireValidOptions(options);
  RequireUsable(gt, 1, gt_name);
  RequireUsable(est, 1, est_name);
  const std::vector<StampMatch> matches =
      AssociateStamps(Stamps(gt), Stamps(est), options.offset_s, options.max_diff_s);
  if (matches.size() < 3) {
    std::ostringstream s;
    s.precision(6);
    s << std::fixed << "only " << matches.size() << " poses of " << est_name << " ("
      << est.front().timestamp << " .. " << est.back().timestamp << ", offset " << options.offset_s
      << " s) lie within " << options.max_diff_s << " s of a pose of " << gt_name << " ("
      << gt.front().timestamp << " .. " << gt.back().timestamp
      << "); the alignment needs at least 3";
    throw DataError(s.str());
  }
  std::vector<Eigen::Vector3d> p_gt;
  std::vector<Eigen::Vector3d> p_est;
  for (const StampMatch& m : matches) {
    p_gt.emplace_back(gt[m.first_index].T_w_c.translation());
    p_est.emplace_back(options.scale * est[m.second_index].T_w_c.translation());
  }
  AteResult result;
  result.T_gt_est = AlignHorn(p_est, p_gt);
  std::vector<double> errors;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    AtePair pair;
    pair.gt_timestamp = matches[i].first_stamp;
    pair.est_timestamp = matches[i].second_stamp;
    pair.p_gt = p_gt[i];
    pair.p_est_aligned = result.T_gt_est * p_est[i];
    pair.error = (pair.p_gt - pair.p_est_aligned).norm();
    errors.push_back(pair.error);
    result.pairs.push_back(pair);
  }
  result.translation = ComputeErrorStats(errors);
  return result;
}

RpeResult ComputeRpe(const Trajectory& gt, const Trajectory& est, const EvaluationOptions& options,
                     const std::string& gt_name, const std::string& est_name) {
  RequireValidOptions(options);
  // Two ground-truth poses for the median interval, two estimated ones for a pair.
  RequireUsable(gt, 2, gt_name);
  RequireUsable(est, 2, est_name);
  const std::vector<double> stamps_gt = Stamps(gt);
  const std::vector<double> stamps_est = Stamps(est);
  const double offset = options.offset_s;

  // As TUM: the overlap test of evaluate_rpe.py (nearest gt stamp, then back to the nearest
  // estimated stamp); fewer than 2 distinct round trips means the files do not overlap.
  std::unordered_set<std::size_t> returned;
  for (double t_est : stamps_est) {
    const double t_gt = stamps_gt[FindClosestIndex(stamps_gt, t_est + offset)];
    returned.insert(FindClosestIndex(stamps_est, t_gt - offset));
  }
  if (returned.size() < 2) {
    throw DataError("the timestamps of " + est_name + " and " + gt_name +
                    " barely overlap; are these the right files?");
  }

  // The pair (i, j): j is the estimate nearest to index_i + delta; as TUM, a pair whose j is
  // the last estimate is dropped (the search clamps there, so delta was not reached).
  std::vector<double> index_est = stamps_est;
  if (options.delta_unit == DeltaUnit::kFrames) std::iota(index_est.begin(), index_est.end(), 0.0);
  std::vector<std::pair<std::size_t, std::size_t>> index_pairs;
  for (std::size_t i = 0; i < index_est.size(); ++i) {
    const std::size_t j = FindClosestIndex(index_est, index_est[i] + options.delta);
    if (j != index_est.size() - 1) index_pairs.emplace_back(i, j);
  }

  // Pairs whose estimate is farther than two median gt periods from any gt stamp are skipped
  // (a gap in the motion capture).
  std::vector<double> intervals;
  for (std::size_t k = 1; k < stamps_gt.size(); ++k) {
    intervals.push_back(stamps_gt[k] - stamps_gt[k - 1]);
  }
  const double gt_max_time_difference = 2.0 * Median(intervals);

  RpeResult result;
  std::vector<double> trans_errors;
  std::vector<double> rot_errors;
  for (const auto& [i, j] : index_pairs) {
    const std::size_t g0 = FindClosestIndex(stamps_gt, stamps_est[i] + offset);
    const std::size_t g1 = FindClosestIndex(stamps_gt, stamps_est[j] + offset);
    if (std::abs(stamps_gt[g0] - (stamps_est[i] + offset)) > gt_max_time_difference ||
        std::abs(stamps_gt[g1] - (stamps_est[j] + offset)) > gt_max_time_difference) {
      continue;
    }
    // As TUM: ominus(a, b) = a^-1 b, and the script compares the motions from pose 1 back to
    // pose 0; the translation norm depends on that order, so it is kept.
    const Eigen::Isometry3d est_motion =
        ScaleTranslation(est[j].T_w_c.inverse() * est[i].T_w_c, options.scale);
    const Eigen::Isometry3d gt_motion = gt[g1].T_w_c.inverse() * gt[g0].T_w_c;
    const Eigen::Isometry3d error = est_motion.inverse() * gt_motion;
    RpePair pair;
    pair.est_timestamp_0 = stamps_est[i];
    pair.est_timestamp_1 = stamps_est[j];
    pair.gt_timestamp_0 = stamps_gt[g0];
    pair.gt_timestamp_1 = stamps_gt[g1];
    pair.translation_error = error.translation().norm();
    pair.rotation_error_rad = RotationAngle(error.linear());
    trans_errors.push_back(pair.translation_error);
    rot_errors.push_back(pair.rotation_error_rad);
    result.pairs.push_back(pair);
  }
  if (result.pairs.size() < 2) {
    std::ostringstream s;
    s << "only " << result.pairs.size() << " relative-pose pairs (delta " << options.delta << " "
      << DeltaUnitName(options.delta_unit) << ") between " << est_name << " (" << est.size()
      << " poses) and " << gt_name << "; the RPE needs at least 2";
    throw DataError(s.str());
  }
  result.translation = ComputeErrorStats(trans_errors);
  // As TUM: statistics of the radians, converted afterwards.
  result.rotation = ScaleErrorStats(ComputeErrorStats(rot_errors), kRadToDeg);
  return result;
}

EvaluationResult EvaluateTrajectories(const Trajectory& gt, const Trajectory& est,
                                      const EvaluationOptions& options, const std::string& gt_name,
                                      const std::string& est_name) {
  RequireValidOptions(options);
  EvaluationResult result;
  result.options = options;
  try {
    result.ate = ComputeAte(gt, est, options, gt_name, est_name);
  } catch (const DataError& e) {
    result.ate_unavailable = e.what();
  }
  try {
    result.rpe = ComputeRpe(gt, est, options, gt_name, est_name);
  } catch (const DataError& e) {
    result.rpe_unavailable = e.what();
  }
  if (!result.ate_unavailable.empty() && !result.rpe_unavailable.empty()) {
    // One message when both fail for the same reason (an empty file, no overlap).
    throw DataError(result.ate_unavailable == result.rpe_unavailable
                        ? result.ate_unavailable
                        : "no ATE: " + result.ate_unavailable +
                              "; no RPE: " + result.rpe_unavailable);
  }
  if (!result.ate_unavailable.empty()) return result;
  result.aligned_estimate.reserve(est.size());
  for (const TimedPose& pose : est) {
    TimedPose aligned;
    aligned.timestamp = pose.timestamp + options.offset_s;
    aligned.T_w_c = result.ate.T_gt_est * ScaleTranslation(pose.T_w_c, options.scale);
    result.aligned_estimate.push_back(aligned);
  }
  return result;
}

}  // namespace ieslam
