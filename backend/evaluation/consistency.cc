#include "backend/evaluation/consistency.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glog/logging.h>
#include <Eigen/Cholesky>

namespace ieslam {
namespace {

// Inverse of the standard normal CDF (Acklam's rational approximation, |error| < 1.2e-9).
double NormalQuantile(double p) {
  CHECK(p > 0.0 && p < 1.0);
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01, -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  const double low = 0.02425;
  if (p < low) {
    const double q = std::sqrt(-2.0 * std::log(p));
    return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  }
  if (p > 1.0 - low) return -NormalQuantile(1.0 - p);
  const double q = p - 0.5, r = q * q;
  return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
         (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
}

}  // namespace

double PoseNees(const Vector6d& estimate, const Vector6d& truth, const Matrix6d& covariance) {
  const Vector6d e = PoseDifference(estimate, truth);
  return e.dot(covariance.ldlt().solve(e));
}

double ChiSquareQuantile(double probability, double dof) {
  CHECK_GT(dof, 0.0);
  const double h = 2.0 / (9.0 * dof);
  const double cube = 1.0 - h + NormalQuantile(probability) * std::sqrt(h);
  return dof * cube * cube * cube;
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
