#include "apps/batch_refinement.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "backend/evaluation.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/trajectory.h"

namespace ieslam {

double AteOfFiles(const std::string& gt_path, const std::string& est_path) {
  try {
    const Trajectory gt = ReadTumTrajectoryForEvaluation(gt_path);
    const Trajectory est = ReadTumTrajectoryForEvaluation(est_path);
    return ComputeAte(gt, est, EvaluationOptions(), gt_path, est_path).translation.rmse;
  } catch (const DataError& e) {
    std::fprintf(stderr, "warning: no ATE for %s: %s\n", est_path.c_str(), e.what());
    return -1.0;
  }
}

Json BaOptionsToJson(const BundleAdjustmentOptions& options) {
  return Json::Object()
      .Set("robust_loss", BaRobustLossName(options.robust_loss))
      .Set("huber_scale", options.huber_scale)
      .Set("rejection_chi2", options.rejection_chi2)
      .Set("max_rejection_rounds", options.max_rejection_rounds)
      .Set("max_iterations", options.max_iterations);
}

namespace {

// Keyed by component: u and v in pixels' sigmas, d in the range's.
Json ResidualCheckToJson(const BundleAdjustmentResult::ResidualCheck& check) {
  const auto by_component = [](const Eigen::Vector3d& v) {
    return Json::Object().Set("u", v[0]).Set("v", v[1]).Set("d", v[2]);
  };
  return Json::Object()
      .Set("observations", check.observations)
      .Set("rms", by_component(check.rms))
      .Set("robust_sigma", by_component(check.robust_sigma))
      .Set("redundancy", check.redundancy)
      .Set("expected_robust_sigma", std::sqrt(std::max(0.0, check.redundancy)));
}

}  // namespace

RefinementOutcome RefineToFiles(const StoredBaProblem& stored, const SlamEstimate& filter_estimate,
                                const BundleAdjustmentOptions& options, const std::string& out,
                                const std::string& gt_path) {
  RefinementOutcome outcome;
  const auto start = std::chrono::steady_clock::now();
  const BundleAdjustmentResult refined =
      SolveBundleAdjustment(stored.problem, stored.camera, options);
  outcome.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Trajectory trajectory;
  for (const auto& [frame, T_w_c] : refined.T_w_c) {
    trajectory.push_back({stored.timestamps.at(frame), T_w_c});
  }
  std::sort(trajectory.begin(), trajectory.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.timestamp < b.timestamp; });
  WriteTumTrajectory(JoinPath(out, "refined.tum"), trajectory, "ieslam bundle-adjusted keyframes");
  if (!gt_path.empty()) outcome.ate_refined_m = AteOfFiles(gt_path, JoinPath(out, "refined.tum"));
  outcome.comparison = ComparisonToJson(
      CompareFilterToSmoother(filter_estimate, SmootherEstimate(refined)), true);
  const Json solver = Json::Object()
                          .Set("initial_cost", refined.initial_cost)
                          .Set("final_cost", refined.final_cost)
                          .Set("iterations", refined.iterations)
                          .Set("residuals", refined.num_residuals)
                          .Set("rejected_observations", static_cast<int>(refined.rejected.size()))
                          .Set("rejection_variance_factor", refined.rejection_variance_factor)
                          .Set("residual_check", ResidualCheckToJson(refined.residual_check))
                          .Set("termination", refined.termination)
                          .Set("seconds", refined.solve_time_s);
  outcome.comparison.Set("ba", solver);
  return outcome;
}

}  // namespace ieslam
