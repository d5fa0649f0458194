#include "selection/pipeline/known_association_run.h"

#include <cmath>

#include <glog/logging.h>

#include "backend/evaluation/consistency.h"
#include "backend/evaluation/evaluation.h"
#include "frontend/simulation/known_association_source.h"
#include "selection/pipeline/pipeline.h"

namespace ieslam {
namespace {

// RMSE of the estimated positions after Horn's alignment onto the true ones (TUM's ATE).
double AlignedRmse(const std::vector<Eigen::Vector3d>& p_est,
                   const std::vector<Eigen::Vector3d>& p_true) {
  const Eigen::Isometry3d T_true_est = AlignHorn(p_est, p_true);
  double sum = 0.0;
  for (size_t i = 0; i < p_est.size(); ++i) {
    sum += (T_true_est * p_est[i] - p_true[i]).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(p_est.size()));
}

// Each selected pose's error, sigmas and NEES against the truth, and their summaries.
void MeasureErrors(const KnownAssociationInput& input, const PipelineResult& result,
                   KnownAssociationMetrics* metrics, std::vector<Eigen::Vector3d>* p_true) {
  std::vector<Eigen::Vector3d> p_est;
  double nees_sum = 0.0;
  int inside = 0;
  for (const int frame : result.selection.selected) {
    if (!result.filter->HasPose(frame)) continue;
    PoseErrorRecord record;
    record.frame = frame;
    const Vector6d& estimate = result.estimate.poses.at(frame);
    const Matrix6d& covariance = result.estimate.pose_covariances.at(frame);
    record.error = PoseDifference(estimate, input.T_w_c_true[frame]);
    record.sigma = covariance.diagonal().cwiseSqrt();
    record.nees = PoseNees(estimate, input.T_w_c_true[frame], covariance);
    nees_sum += record.nees;
    for (int axis = 0; axis < 6; ++axis) {
      inside += std::abs(record.error[axis]) <= 2.0 * record.sigma[axis] ? 1 : 0;
    }
    p_est.push_back(estimate.head<3>());
    p_true->push_back(input.T_w_c_true[frame].head<3>());
    metrics->pose_errors.push_back(record);
  }
  const int count = static_cast<int>(metrics->pose_errors.size());
  metrics->mean_nees = nees_sum / count;
  metrics->within_2sigma = static_cast<double>(inside) / (6.0 * count);
  metrics->final_pose_error_m = metrics->pose_errors.back().error.head<3>().norm();
  if (count >= 3) metrics->ate_rmse_m = AlignedRmse(p_est, *p_true);
}

}  // namespace

KnownAssociationMetrics RunKnownAssociation(const KnownAssociationInput& input,
                                            const SelectorOptions& selector,
                                            const InformationFilterOptions& filter,
                                            const BundleAdjustmentOptions* refine) {
  const int n = static_cast<int>(input.observations.size());
  CHECK_EQ(static_cast<int>(input.T_w_c_true.size()), n);
  CHECK_GT(n, 0);
  std::vector<double> timestamps(n);
  for (int k = 0; k < n; ++k) timestamps[k] = k;
  KnownAssociationSource source(input.observations, timestamps, input.camera,
                                PoseToIsometry(input.T_w_c_true[0]), selector.min_common_features);
  PipelineOptions options;
  options.selector = selector;
  options.filter = filter;
  options.refine = refine != nullptr && selector.kind != SelectorKind::kDeadReckoning;
  if (refine != nullptr) options.ba = *refine;
  options.depth_alignment.rounds = 0;
  PipelineResult result = RunPipeline(&source, input.camera, options);

  KnownAssociationMetrics metrics;
  const SelectionResult& selection = result.selection;
  metrics.frames_total = n;
  metrics.frames_used = static_cast<int>(selection.selected.size());
  metrics.seconds_selection = selection.seconds_selection;
  metrics.seconds_filter = selection.seconds_filter;
  metrics.seconds = selection.seconds_selection + selection.seconds_filter;
  if (selector.kind != SelectorKind::kDeadReckoning) {
    metrics.state_dim = result.filter->state_dim();
    metrics.poses = result.filter->num_poses();
    metrics.features = result.filter->num_features();
    std::vector<Eigen::Vector3d> p_true;
    MeasureErrors(input, result, &metrics, &p_true);
    if (result.refinement && result.refinement->ok() && p_true.size() >= 3) {
      const BundleAdjustmentResult& ba = result.refinement->refined();
      metrics.seconds_ba = ba.solve_time_s;
      std::vector<Eigen::Vector3d> p_refined;
      for (const PoseErrorRecord& record : metrics.pose_errors) {
        p_refined.push_back(ba.T_w_c.at(record.frame).translation());
      }
      metrics.refined_ate_rmse_m = AlignedRmse(p_refined, p_true);
    }
  }
  metrics.selection = std::move(result.selection);
  return metrics;
}

}  // namespace ieslam
