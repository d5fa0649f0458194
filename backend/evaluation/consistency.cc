#include "backend/evaluation/consistency.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glog/logging.h>
#include <Eigen/Cholesky>
#include <Eigen/Geometry>

namespace ieslam {
namespace {

Eigen::Matrix3d EulerRotation(const Eigen::Vector3d& alpha_beta_gamma) {
  Vector6d pose = Vector6d::Zero();
  pose.tail<3>() = alpha_beta_gamma;
  return PoseToIsometry(pose).linear();
}

Eigen::Vector3d RotationVector(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// The rotation error as a world-frame rotation vector, log(R_estimate R_truth^T), and its
// NEES against the Euler block of the covariance mapped by d log(R(a + da) R(a)^T) / da.
void RotationError(const Vector6d& estimate, const Vector6d& truth, const Matrix6d& covariance,
                   double* angle_deg, double* nees) {
  const Eigen::Matrix3d R = EulerRotation(estimate.tail<3>());
  const Eigen::Vector3d omega = RotationVector(R * EulerRotation(truth.tail<3>()).transpose());
  Eigen::Matrix3d E;
  constexpr double kStep = 1e-6;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d a = estimate.tail<3>();
    a[i] += kStep;
    E.col(i) = RotationVector(EulerRotation(a) * R.transpose()) / kStep;
  }
  const Eigen::Matrix3d P = E * covariance.bottomRightCorner<3, 3>() * E.transpose();
  *angle_deg = omega.norm() * 180.0 / M_PI;
  *nees = omega.dot(P.ldlt().solve(omega));
}

}  // namespace

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
  double nees_sum = 0.0, rotation_nees_sum = 0.0;
  std::vector<double> angles;
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
    RotationError(estimate, t->second, P->second, &pose.rotation_error_deg, &pose.rotation_nees);
    ++c.poses;
    nees_sum += pose.nees;
    rotation_nees_sum += pose.rotation_nees;
    angles.push_back(pose.rotation_error_deg);
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
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  c.median_rotation_error_deg = angles[angles.size() / 2];
  c.mean_rotation_nees = rotation_nees_sum / c.poses;
  c.rotation_nees_band = NeesBand(3, c.poses);
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
