#include "selection/pipeline/refinement.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <set>
#include <string>
#include <utility>

#include "core/stopwatch.h"

namespace ieslam {
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

Json SolverToJson(const BundleAdjustmentResult& r) {
  return Json::Object()
      .Set("initial_cost", r.initial_cost)
      .Set("final_cost", r.final_cost)
      .Set("iterations", r.iterations)
      .Set("solves", r.solves)
      .Set("linear_solver", r.linear_solver)
      .Set("reduced_system_density", r.reduced_system_density)
      .Set("residuals", r.num_residuals)
      .Set("rejected_observations", static_cast<int>(r.rejected.size()))
      .Set("rejected_share",
           r.observations > 0 ? static_cast<double>(r.rejected.size()) / r.observations : 0.0)
      .Set("rejection_variance_factor", r.rejection_variance_factor)
      .Set("residual_check", ResidualCheckToJson(r.residual_check))
      .Set("termination", r.termination)
      .Set("seconds", r.solve_time_s)
      .Set("covariance_seconds", r.covariance_time_s);
}

// Coefficients with their sigmas and correlations, and what they gain: chi_square_drop is
// twice the cost they take off (chi-square with 3 degrees of freedom were there no correction
// and Q right).
Json DepthCorrectionToJson(const DepthCorrectionEstimate& e) {
  Json json = Json::Object().Set("usable", e.usable);
  if (!e.failure.empty()) json.Set("failure", e.failure);
  const Eigen::Vector3d sigma = e.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  Json coefficients = Json::Array(), sigmas = Json::Array(), correlation = Json::Array();
  for (int i = 0; i < 3; ++i) {
    coefficients.Push(e.coefficients[i]);
    sigmas.Push(sigma[i]);
    Json row = Json::Array();
    for (int j = 0; j < 3; ++j) {
      row.Push(sigma[i] > 0.0 && sigma[j] > 0.0 ? e.covariance(i, j) / (sigma[i] * sigma[j]) : 0.0);
    }
    correlation.Push(row);
  }
  return json.Set("coefficients", coefficients)
      .Set("sigma", sigmas)
      .Set("correlation", correlation)
      .Set("observations", e.observations)
      .Set("chi_square_drop", 2.0 * (e.cost_without - e.cost_with))
      .Set("iterations", e.iterations)
      .Set("seconds", e.seconds);
}

Json DepthAlignmentToJson(const Refinement& refinement) {
  const DepthAlignmentStats& stats = refinement.depth_stats;
  const FilterSmootherComparison& change = refinement.change_from_features;
  return Json::Object()
      .Set("rounds", stats.rounds)
      .Set("pairs_tried", stats.pairs_tried)
      .Set("constraints", stats.constraints)
      .Set("rejected_constraints", refinement.depth_aligned.rejected_relative_poses)
      .Set("alignment_iterations", stats.iterations)
      .Set("constraint_variance_factor", stats.variance_factor)
      .Set("sample_step", stats.sample_step)
      .Set("frames", refinement.depth_frames)
      .Set("frames_left_out", refinement.depth_frames_left_out)
      .Set("mean_overlap", stats.mean_overlap)
      .Set("seconds_alignment", stats.seconds_alignment)
      .Set("seconds_screen", stats.seconds_screen)
      .Set("seconds_ba", stats.seconds_ba)
      .Set("change_from_ba_translation_rmse_m", change.translation_m.rmse)
      .Set("change_from_ba_rotation_rmse_deg", change.rotation_deg.rmse)
      .Set("used", refinement.depth_alignment_used)
      .Set("ba", SolverToJson(refinement.depth_aligned));
}

// Why a features' solve of `problem` is no refinement (empty if it is one).
std::string FeaturesFailure(const BundleAdjustmentProblem& problem,
                            const BundleAdjustmentResult& solved) {
  if (problem.observations.empty()) return "the problem has no observations";
  if (solved.interrupted) return "the bundle adjustment was interrupted";
  if (!solved.usable || solved.num_residuals == 0) {
    return "the bundle adjustment failed (" + solved.termination + ")";
  }
  return "";
}

// `problem` solved with its registered observations in place of the filter's.
BundleAdjustmentProblem WithRegistered(const BundleAdjustmentProblem& problem) {
  BundleAdjustmentProblem registered = problem;
  registered.observations = problem.registered;
  registered.registered.clear();
  return registered;
}

// The registered observations the filter's gate refused: those of frame and feature pairs
// the problem's own observations lack (a frame observes a feature once).
std::set<std::pair<int, int64_t>> Refused(const BundleAdjustmentProblem& problem) {
  std::set<std::pair<int, int64_t>> taken, refused;
  for (const BundleAdjustmentObservation& o : problem.observations) {
    taken.emplace(o.frame_id, o.observation.feature_id);
  }
  for (const BundleAdjustmentObservation& o : problem.registered) {
    if (!taken.count({o.frame_id, o.observation.feature_id})) {
      refused.emplace(o.frame_id, o.observation.feature_id);
    }
  }
  return refused;
}

// The features' solve of `registered` (WithRegistered(problem)) into refinement->registered, and
// how many of the gate's refusals its rejection rounds kept. An interruption is the refinement's
// failure; another failure leaves registered_used false, with a warning.
void SolveRegistered(const BundleAdjustmentProblem& problem,
                     const BundleAdjustmentProblem& registered, const PinholeCamera& camera,
                     const BundleAdjustmentOptions& ba, Refinement* refinement) {
  const std::set<std::pair<int, int64_t>> refused = Refused(problem);
  refinement->refused = static_cast<int>(refused.size());
  refinement->registered = SolveBundleAdjustment(registered, camera, ba);
  const std::string failure = FeaturesFailure(registered, refinement->registered);
  if (refinement->registered.interrupted) {
    refinement->failure = failure;
    return;
  }
  if (!failure.empty()) {
    refinement->warnings.push_back(failure +
                                   " with every registered observation; the refinement rests "
                                   "on the filter's own");
    return;
  }
  refinement->registered_used = true;
  int rejected = 0;
  for (const BundleAdjustmentObservation& o : refinement->registered.rejected) {
    rejected += static_cast<int>(refused.count({o.frame_id, o.observation.feature_id}));
  }
  refinement->refused_kept = refinement->refused - rejected;
}

// `solved` again from `problem` with `ba`'s covariances (after the solve meant to bring them
// failed), its failure the refinement's.
void SolveAgainWithCovariances(const BundleAdjustmentProblem& problem, const PinholeCamera& camera,
                               const BundleAdjustmentOptions& ba, BundleAdjustmentResult* solved,
                               Refinement* refinement) {
  *solved = SolveBundleAdjustment(problem, camera, ba);
  refinement->failure = FeaturesFailure(problem, *solved);
}

// Refine without applying a depth correction (the estimate is made when ba asks for it).
Refinement RefineOnce(const BundleAdjustmentProblem& problem, const PinholeCamera& camera,
                      const SlamEstimate& filter_estimate, const BundleAdjustmentOptions& ba,
                      const DepthAlignmentOptions& depth, const RangeClouds* clouds,
                      const Eigen::Isometry3d& T_colour_range) {
  Refinement refinement;
  // Only the solve that is the refinement computes covariances: with clouds to align the
  // depth-aligned one, else the registered one when tried, else the check's; a fallback
  // solves again for them.
  const auto no_covariances = [](const BundleAdjustmentResult&) { return false; };
  const bool clouds_given = clouds != nullptr && depth.rounds > 0 && !clouds->clouds.empty();
  refinement.registered_tried = ba.refine_registered && !problem.registered.empty();
  BundleAdjustmentOptions features_ba = ba;
  if (clouds_given) features_ba.covariances_wanted = no_covariances;
  BundleAdjustmentOptions check_ba = features_ba;
  if (refinement.registered_tried) check_ba.covariances_wanted = no_covariances;
  refinement.smoothed = SolveBundleAdjustment(problem, camera, check_ba);
  refinement.failure = FeaturesFailure(problem, refinement.smoothed);
  refinement.depth_correction_tried = ba.estimate_depth_correction && refinement.ok();
  if (refinement.depth_correction_tried) {
    refinement.depth_correction =
        EstimateDepthCorrection(problem, refinement.smoothed, camera, T_colour_range, ba);
    if (refinement.depth_correction.interrupted) {
      refinement.failure = "the depth correction's estimate was interrupted";
    } else if (!refinement.depth_correction.usable) {
      refinement.warnings.push_back("no depth correction: " + refinement.depth_correction.failure);
    }
  }
  BundleAdjustmentProblem registered;
  if (refinement.registered_tried && refinement.ok()) {
    registered = WithRegistered(problem);
    SolveRegistered(problem, registered, camera, features_ba, &refinement);
    if (refinement.ok() && !refinement.registered_used && !clouds_given && ba.compute_covariances) {
      SolveAgainWithCovariances(problem, camera, features_ba, &refinement.smoothed, &refinement);
    }
  }
  const BundleAdjustmentProblem& solved = refinement.registered_used ? registered : problem;
  refinement.depth_alignment_tried = clouds_given && refinement.ok();
  if (refinement.depth_alignment_tried) {
    BundleAdjustmentProblem started = solved;
    started.T_w_c = refinement.features().T_w_c;
    started.p_w = refinement.features().p_w;
    refinement.depth_aligned = SolveWithDepthAlignment(started, camera, clouds->clouds, ba, depth,
                                                       &refinement.depth_stats);
    refinement.depth_frames = static_cast<int>(clouds->clouds.size());
    refinement.depth_frames_left_out = clouds->frames_left_out;
    refinement.depth_alignment_used = refinement.depth_aligned.usable;
    if (refinement.depth_aligned.interrupted) {
      refinement.failure = "the depth-aligned refinement was interrupted";
    } else if (!refinement.depth_alignment_used) {
      refinement.warnings.push_back("the depth-aligned refinement failed (" +
                                    refinement.depth_aligned.termination +
                                    "); refined.tum is the bundle adjustment of the features");
      // The same solve again, now with the covariances it left out (the same result with
      // one solver thread; Ceres' threads may sum in another order).
      if (ba.compute_covariances) {
        SolveAgainWithCovariances(
            solved, camera, ba,
            refinement.registered_used ? &refinement.registered : &refinement.smoothed,
            &refinement);
      }
    }
  }
  refinement.comparison =
      CompareFilterToSmoother(filter_estimate, SmootherEstimate(refinement.smoothed));
  if (refinement.registered_used) {
    refinement.registered_comparison =
        CompareFilterToSmoother(filter_estimate, SmootherEstimate(refinement.registered));
  }
  if (refinement.depth_alignment_tried) {
    refinement.change_from_features = CompareFilterToSmoother(
        SmootherEstimate(refinement.features()), SmootherEstimate(refinement.depth_aligned));
  }
  return refinement;
}

// Whether a solve of `refinement` was stopped by the caller's stop.
bool Interrupted(const Refinement& refinement) {
  return refinement.smoothed.interrupted || refinement.registered.interrupted ||
         refinement.depth_aligned.interrupted;
}

// The refinement of `problem` and `clouds` again with every range corrected by the usable
// estimate in *refinement, as refinement->corrected; its warnings join refinement's. A failure
// leaves the uncorrected refinement, with a warning; an interruption is refinement's failure.
void RefineCorrected(const BundleAdjustmentProblem& problem, const PinholeCamera& camera,
                     const SlamEstimate& filter_estimate, const BundleAdjustmentOptions& ba,
                     const DepthAlignmentOptions& depth, const RangeClouds* clouds,
                     const Eigen::Isometry3d& T_colour_range, Refinement* refinement) {
  const auto start = std::chrono::steady_clock::now();
  const std::array<double, 3>& k = refinement->depth_correction.coefficients;
  const std::string refused = DepthCorrectionRefused(problem, camera, T_colour_range, k);
  if (!refused.empty()) {
    refinement->warnings.push_back("the depth correction is not applied: " + refused);
    return;
  }
  RangeClouds corrected_clouds;
  if (clouds != nullptr) {
    corrected_clouds.frames_left_out = clouds->frames_left_out;
    for (const auto& [frame, cloud] : clouds->clouds) {
      corrected_clouds.clouds.emplace(frame, WithRangesCorrected(cloud, k));
    }
  }
  BundleAdjustmentOptions corrected_ba = ba;
  corrected_ba.estimate_depth_correction = false;
  corrected_ba.apply_depth_correction = false;
  auto corrected = std::make_shared<Refinement>(RefineOnce(
      WithRangesCorrected(problem, camera, T_colour_range, k), camera, filter_estimate,
      corrected_ba, depth, clouds != nullptr ? &corrected_clouds : nullptr, T_colour_range));
  corrected->seconds = SecondsSince(start);
  for (const std::string& warning : corrected->warnings) {
    refinement->warnings.push_back("with the depth correction applied: " + warning);
  }
  if (!corrected->ok()) {
    if (Interrupted(*corrected)) {
      refinement->failure = "with the depth correction applied: " + corrected->failure;
    } else {
      refinement->warnings.push_back("the refinement with the depth correction failed (" +
                                     corrected->failure + "); refined.tum is the one without");
    }
    return;
  }
  refinement->change_from_uncorrected = CompareFilterToSmoother(
      SmootherEstimate(refinement->uncorrected_refined()), SmootherEstimate(corrected->refined()));
  refinement->corrected = std::move(corrected);
}

}  // namespace

Refinement Refine(const BundleAdjustmentProblem& problem, const PinholeCamera& camera,
                  const SlamEstimate& filter_estimate, const BundleAdjustmentOptions& ba,
                  const DepthAlignmentOptions& depth, const RangeClouds* clouds,
                  const Eigen::Isometry3d& T_colour_range) {
  const auto start = std::chrono::steady_clock::now();
  Refinement refinement =
      RefineOnce(problem, camera, filter_estimate, ba, depth, clouds, T_colour_range);
  if (ba.apply_depth_correction && refinement.ok() && refinement.depth_correction_tried &&
      refinement.depth_correction.usable) {
    RefineCorrected(problem, camera, filter_estimate, ba, depth, clouds, T_colour_range,
                    &refinement);
  }
  refinement.seconds = SecondsSince(start);
  return refinement;
}

Trajectory SolvedTrajectory(const BundleAdjustmentResult& solved,
                            const std::map<int, double>& timestamps) {
  Trajectory trajectory;
  for (const auto& [frame, T_w_c] : solved.T_w_c) {
    trajectory.push_back({timestamps.at(frame), T_w_c});
  }
  std::sort(trajectory.begin(), trajectory.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.timestamp < b.timestamp; });
  return trajectory;
}

Trajectory RefinedTrajectory(const Refinement& refinement,
                             const std::map<int, double>& timestamps) {
  return SolvedTrajectory(refinement.refined(), timestamps);
}

std::optional<Rig> CorrectedCalibration(const Refinement& refinement, const Rig& rig,
                                        std::vector<std::string>* warnings) {
  if (!refinement.depth_correction_tried || !refinement.depth_correction.usable) return {};
  Rig corrected = rig;
  corrected.range = WithDepthCorrection(rig.range, refinement.depth_correction);
  std::string why;
  if (corrected.Check(&why)) return corrected;
  warnings->push_back("the estimated depth correction makes no calibration (" + why +
                      "): corrected_calib.yaml is not written");
  return {};
}

Json RefinementToJson(const Refinement& refinement) {
  Json json = ComparisonToJson(refinement.comparison, true);
  json.Set("ba", SolverToJson(refinement.smoothed));
  if (refinement.registered_tried) {
    Json registered = Json::Object()
                          .Set("used", refinement.registered_used)
                          .Set("refused_by_the_gate", refinement.refused);
    if (refinement.registered_used) {
      registered.Set("refused_kept", refinement.refused_kept)
          .Set("filter_vs_this", ComparisonToJson(refinement.registered_comparison, false));
    }
    json.Set("registered", registered.Set("ba", SolverToJson(refinement.registered)));
  }
  if (refinement.depth_alignment_tried)
    json.Set("depth_alignment", DepthAlignmentToJson(refinement));
  if (refinement.depth_correction_tried) {
    Json correction = DepthCorrectionToJson(refinement.depth_correction);
    correction.Set("applied", refinement.corrected != nullptr);
    if (refinement.corrected) {
      const FilterSmootherComparison& change = refinement.change_from_uncorrected;
      correction.Set("change_from_uncorrected_translation_rmse_m", change.translation_m.rmse)
          .Set("change_from_uncorrected_rotation_rmse_deg", change.rotation_deg.rmse)
          .Set("refinement_seconds", refinement.corrected->seconds)
          .Set("refinement", RefinementToJson(*refinement.corrected));
    }
    json.Set("depth_correction", correction);
  }
  return json;
}

}  // namespace ieslam
