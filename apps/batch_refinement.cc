#include "apps/batch_refinement.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "backend/evaluation/evaluation.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/stopwatch.h"
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

std::map<int, RangeCloud> LoadRangeClouds(const Dataset& dataset, const StoredBaProblem& stored,
                                          const RangeCloudOptions& options,
                                          const std::string& command, int* left_out) {
  constexpr double kSameTimestampS = 1e-4;
  const PinholeCamera& a = dataset.rig().colour;
  const PinholeCamera& b = stored.camera;
  if (a.width != b.width || a.height != b.height || std::abs(a.fx - b.fx) > 1e-6 ||
      std::abs(a.fy - b.fy) > 1e-6 || std::abs(a.cx - b.cx) > 1e-6 ||
      std::abs(a.cy - b.cy) > 1e-6) {
    throw DataError(dataset.directory() + ": its colour camera (" + std::to_string(a.fx) + ", " +
                    std::to_string(a.fy) + ", " + std::to_string(a.cx) + ", " +
                    std::to_string(a.cy) + ") is not the run's (" + std::to_string(b.fx) + ", " +
                    std::to_string(b.fy) + ", " + std::to_string(b.cx) + ", " +
                    std::to_string(b.cy) + "): another calibration or dataset");
  }
  *left_out = 0;
  std::map<int, RangeCloud> clouds;
  for (const auto& [frame, T_w_c] : stored.problem.T_w_c) {
    const auto stamp = stored.timestamps.find(frame);
    int index = -1;
    if (stamp != stored.timestamps.end()) {
      for (int i = 0; i < dataset.size() && index < 0; ++i) {
        if (std::abs(dataset.info(i).timestamp - stamp->second) <= kSameTimestampS) index = i;
      }
    }
    if (index < 0) {
      std::fprintf(stderr,
                   "%s: warning: frame %d left out of the depth alignment: no frame of %s at "
                   "its timestamp\n",
                   command.c_str(), frame, dataset.directory().c_str());
      ++*left_out;
      continue;
    }
    try {
      const Frame loaded = dataset.Load(index);
      clouds[frame] =
          MakeRangeCloud(loaded.depth, dataset.rig().range, dataset.rig().T_colour_range, options,
                         "frame " + std::to_string(frame));
    } catch (const DataError& e) {
      std::fprintf(stderr, "%s: warning: frame %d left out of the depth alignment: %s\n",
                   command.c_str(), frame, e.what());
      ++*left_out;
    }
  }
  if (clouds.empty() && !stored.problem.T_w_c.empty()) {
    throw DataError(dataset.directory() + ": none of the run's " +
                    std::to_string(stored.problem.T_w_c.size()) +
                    " selected frames found at their timestamps: not the run's dataset");
  }
  return clouds;
}

Json DepthAlignmentOptionsToJson(const DepthAlignmentOptions& options,
                                 const RangeCloudOptions& cloud) {
  return Json::Object()
      .Set("rounds", options.rounds)
      .Set("grid_step", cloud.step)
      .Set("sample_step", options.sample_step)
      .Set("initial_gate_m", options.initial_gate_m)
      .Set("final_gate_m", options.final_gate_m)
      .Set("max_normal_angle_deg", options.max_normal_angle_deg)
      .Set("huber_sigmas", options.huber_sigmas)
      .Set("min_overlap", options.min_overlap)
      .Set("max_robust_sigma", options.max_robust_sigma)
      .Set("max_partners", options.max_partners);
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
                                const std::string& gt_path, const DepthRefinement* depth) {
  RefinementOutcome outcome;
  const auto start = std::chrono::steady_clock::now();
  const BundleAdjustmentResult smoothed =
      SolveBundleAdjustment(stored.problem, stored.camera, options);
  BundleAdjustmentResult depth_aligned;
  DepthAlignmentStats stats;
  const bool align =
      depth != nullptr && depth->options.rounds > 0 && !depth->clouds.empty() && smoothed.usable;
  if (align) {
    BundleAdjustmentProblem problem = stored.problem;
    problem.T_w_c = smoothed.T_w_c;
    problem.p_w = smoothed.p_w;
    depth_aligned = SolveWithDepthAlignment(problem, stored.camera, depth->clouds, options,
                                            depth->options, &stats);
  }
  // A depth-aligned solve that failed leaves refined.tum to the bundle adjustment.
  const bool aligned = align && depth_aligned.usable;
  if (align && !aligned) {
    std::fprintf(stderr,
                 "warning: the depth-aligned refinement failed (%s); refined.tum is the "
                 "bundle adjustment of the features\n",
                 depth_aligned.termination.c_str());
  }
  const BundleAdjustmentResult& refined = aligned ? depth_aligned : smoothed;
  outcome.seconds = SecondsSince(start);
  Trajectory trajectory;
  for (const auto& [frame, T_w_c] : refined.T_w_c) {
    trajectory.push_back({stored.timestamps.at(frame), T_w_c});
  }
  std::sort(trajectory.begin(), trajectory.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.timestamp < b.timestamp; });
  WriteTumTrajectory(JoinPath(out, "refined.tum"), trajectory, "ieslam bundle-adjusted keyframes");
  if (!gt_path.empty()) outcome.ate_refined_m = AteOfFiles(gt_path, JoinPath(out, "refined.tum"));
  outcome.comparison =
      ComparisonToJson(CompareFilterToSmoother(filter_estimate, SmootherEstimate(smoothed)), true);
  const auto solver = [](const BundleAdjustmentResult& r) {
    return Json::Object()
        .Set("initial_cost", r.initial_cost)
        .Set("final_cost", r.final_cost)
        .Set("iterations", r.iterations)
        .Set("residuals", r.num_residuals)
        .Set("rejected_observations", static_cast<int>(r.rejected.size()))
        .Set("rejection_variance_factor", r.rejection_variance_factor)
        .Set("residual_check", ResidualCheckToJson(r.residual_check))
        .Set("termination", r.termination)
        .Set("seconds", r.solve_time_s);
  };
  outcome.comparison.Set("ba", solver(smoothed));
  if (align) {
    // refined.tum: where it differs from the smoother compared above, and by how much.
    const FilterSmootherComparison change =
        CompareFilterToSmoother(SmootherEstimate(smoothed), SmootherEstimate(depth_aligned));
    const Json summary = Json::Object()
                             .Set("rounds", stats.rounds)
                             .Set("pairs_tried", stats.pairs_tried)
                             .Set("constraints", stats.constraints)
                             .Set("rejected_constraints", depth_aligned.rejected_relative_poses)
                             .Set("frames", static_cast<int>(depth->clouds.size()))
                             .Set("frames_left_out", depth->frames_left_out)
                             .Set("mean_overlap", stats.mean_overlap)
                             .Set("seconds_alignment", stats.seconds_alignment)
                             .Set("seconds_ba", stats.seconds_ba)
                             .Set("change_from_ba_translation_rmse_m", change.translation_m.rmse)
                             .Set("change_from_ba_rotation_rmse_deg", change.rotation_deg.rmse)
                             .Set("used", aligned)
                             .Set("ba", solver(depth_aligned));
    outcome.comparison.Set("depth_alignment", summary);
  }
  return outcome;
}

}  // namespace ieslam
