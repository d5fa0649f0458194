#include "backend/evaluation/consistency.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glog/logging.h>
#include <Eigen/Cholesky>

namespace ieslam {

double PoseNees(const Vector6d& estimate, const Vector6d& truth, const Matrix6d& covariance) {
  const Vector6d e = PoseDifference(estimate, truth);
  return e.dot(covariance.ldlt().solve(e));
}

std::pair<double, double> NeesBand(int dim, int runs, double confidence) {
  CHECK_GT(dim, 0);
  CHECK_GT(runs, 0);
  const double dof = static_cast<double>(dim) * runs;
  return {ChiSquareQuantile((1.0 - confidence) / 2.0, dof) / runs,
          ChiSquareQuantile((1.0 + confidence) / 2.0, dof) / runs};
}

PoseConsistency EvaluatePoseConsistency(const std::map<int, Vector6d>& estimates,
                                        const std::map<int, Matrix6d>& covariances,
                                        const std::map<int, Vector6d>& truth) {
  PoseConsistency c;
  std::array<int, 6> inside{};
  std::vector<double> ratios;
  double nees_sum = 0.0;
  for (const auto& [frame, estimate] : estimates) {
    const auto P = covariances.find(frame);
    const auto t = truth.find(frame);
    if (P == covariances.end() || t == truth.end()) continue;
    const Eigen::LLT<Matrix6d> llt(P->second);
    if (llt.info() != Eigen::Success) continue;
    PoseConsistency::Pose pose;
    pose.frame = frame;
    pose.error = PoseDifference(estimate, t->second);
    pose.sigma = P->second.diagonal().cwiseSqrt();
    pose.nees = pose.error.dot(llt.solve(pose.error));
    ++c.poses;
    nees_sum += pose.nees;
    for (int i = 0; i < 6; ++i) {
      if (std::abs(pose.error[i]) <= 2.0 * pose.sigma[i]) ++inside[i];
      if (i < 3) ratios.push_back(std::abs(pose.error[i]) / pose.sigma[i]);
    }
    c.per_pose.push_back(pose);
  }
  if (c.poses == 0) return c;
  for (int i = 0; i < 6; ++i)
    c.inside_2sigma_per_axis[i] = static_cast<double>(inside[i]) / c.poses;
  c.inside_2sigma = static_cast<double>(inside[0] + inside[1] + inside[2]) / (3.0 * c.poses);
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  c.median_error_over_sigma = ratios[ratios.size() / 2];
  c.mean_nees = nees_sum / c.poses;
  c.nees_band = NeesBand(6, c.poses);
  return c;
}

std::map<int, Vector6d> TruthInEstimateFrame(const Trajectory& ground_truth,
                                             const std::map<int, double>& timestamps,
                                             const std::map<int, Vector6d>& estimates,
                                             double max_gap_s) {
  std::map<int, Vector6d> truth;
  int anchor = -1;
  for (const auto& [frame, estimate] : estimates) {
    if (anchor < 0 || timestamps.at(frame) < timestamps.at(anchor)) anchor = frame;
  }
  if (anchor < 0) return truth;
  const std::optional<Eigen::Isometry3d> gt_anchor =
      InterpolatePose(ground_truth, timestamps.at(anchor), max_gap_s);
  if (!gt_anchor) return truth;
  const Eigen::Isometry3d T_est_gt = PoseToIsometry(estimates.at(anchor)) * gt_anchor->inverse();
  for (const auto& [frame, estimate] : estimates) {
    if (frame == anchor) continue;
    const std::optional<Eigen::Isometry3d> gt =
        InterpolatePose(ground_truth, timestamps.at(frame), max_gap_s);
    if (gt) truth[frame] = IsometryToPose(T_est_gt * *gt);
  }
  return truth;
}

}  // namespace ieslam
