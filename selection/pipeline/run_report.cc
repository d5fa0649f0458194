#include "selection/pipeline/run_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "core/version.h"

namespace ieslam {
namespace {

// The q-quantile of ascending, non-empty `sorted` (the value at floor(q n)).
double SortedQuantile(const std::vector<double>& sorted, double q) {
  return sorted[std::min(sorted.size() - 1, static_cast<size_t>(q * sorted.size()))];
}

// [{frame, timestamp, sigma: [x, y, z (m), alpha, beta, gamma (rad)]}] from the estimate's
// pose covariances, in frame order: the paper's Figs. 3-4 and 12 with real data.
Json PoseSigmasToJson(const SlamEstimate& estimate, const std::map<int, double>& timestamps) {
  Json sigmas = Json::Array();
  for (const auto& [frame, P] : estimate.pose_covariances) {
    Json sigma = Json::Array();
    for (int i = 0; i < 6; ++i) sigma.Push(std::sqrt(std::max(0.0, P(i, i))));
    sigmas.Push(Json::Object()
                    .Set("frame", frame)
                    .Set("timestamp", timestamps.at(frame))
                    .Set("sigma", sigma));
  }
  return sigmas;
}

Json DecisionsToJson(const Dataset& dataset, const std::vector<SelectionDecision>& decisions) {
  Json json = Json::Array();
  for (const SelectionDecision& d : decisions) {
    json.Push(Json::Object()
                  .Set("candidates", Json::ArrayOf(SourceIndices(dataset, d.candidates)))
                  .Set("gains", Json::ArrayOf(d.gains))
                  .Set("map_gains", Json::ArrayOf(d.map_gains))
                  .Set("added", Json::ArrayOf(SourceIndices(dataset, d.added)))
                  .Set("reason", d.reason));
  }
  return json;
}

}  // namespace

std::vector<std::pair<std::string, double>> RunWallStages(const RunResult& run, bool refine,
                                                          double total_seconds,
                                                          double outputs_seconds) {
  const SourceTimings& t = run.frontend;
  const PipelineResult& p = run.pipeline;
  const double registration = std::min(t.caller(), p.selection.seconds_selection);
  std::vector<std::pair<std::string, double>> stages = {
      {"setup", run.setup_seconds},
      {"registration", registration},
      {"selection", p.selection.seconds_selection - registration},
      {"filter", p.selection.seconds_filter},
      {"covariance", p.covariance_seconds},
      {"map", p.clouds_seconds + run.map_seconds},
      {"evaluation", run.evaluation_seconds},
      {"outputs", outputs_seconds}};
  if (refine) stages.emplace_back("ba", p.refinement ? p.refinement->seconds : 0.0);
  double named = 0.0;
  for (const auto& stage : stages) named += stage.second;
  stages.emplace_back("other", total_seconds - named);
  return stages;
}

namespace {

Json SecondsToJson(const RunResult& run, bool refine, double total_seconds,
                   double outputs_seconds) {
  const SourceTimings& t = run.frontend;
  Json seconds =
      Json::Object().Set("total", total_seconds).Set("frontend", t.total()).Set("load", t.load_s);
  for (const auto& [name, value] : RunWallStages(run, refine, total_seconds, outputs_seconds)) {
    seconds.Set(name, value);
  }
  const std::vector<double>& quarters = run.pipeline.selection.seconds_per_frame_by_quarter;
  seconds.Set("per_frame_by_quarter", Json::ArrayOf(quarters));
  if (quarters.size() == 4 && quarters.front() > 0.0) {
    seconds.Set("last_to_first_quarter", quarters.back() / quarters.front());
  }
  seconds["frontend_stages"]
      .Set("load", t.load_s)
      .Set("extract", t.extract_s)
      .Set("lift", t.lift_s)
      .Set("match", t.match_s)
      .Set("ransac", t.ransac_s)
      .Set("database", t.database_s)
      .Set("fetch_wall", t.fetch_wall_s);
  return seconds;
}

// The compensation's readout time, the frames it had a velocity for, and their angular rates.
Json RollingShutterToJson(const Dataset& dataset, const RunResult& run) {
  const FrameVelocities::Counts& counts = *run.velocity_counts;
  Json rates = Json::Object();
  std::vector<double> deg_s;
  for (double rate : run.angular_rates_rad_s) deg_s.push_back(rate * 180.0 / M_PI);
  if (!deg_s.empty()) {
    std::sort(deg_s.begin(), deg_s.end());
    rates.Set("median", SortedQuantile(deg_s, 0.5))
        .Set("p90", SortedQuantile(deg_s, 0.9))
        .Set("max", deg_s.back());
  }
  return Json::Object()
      .Set("readout_s", dataset.rig().colour_readout_s)
      .Set("velocity_from_both_neighbours", counts.both)
      .Set("velocity_from_one_neighbour", counts.one)
      .Set("no_velocity", counts.none)
      .Set("angular_rate_deg_s", rates);
}

// Only what could be computed; null when nothing could.
Json AteToJson(const RunResult& run, bool refine) {
  Json ate = Json::Object();
  if (run.ate_keyframes_m >= 0.0) ate.Set("keyframes", run.ate_keyframes_m);
  if (run.ate_trajectory_m >= 0.0) ate.Set("trajectory", run.ate_trajectory_m);
  if (refine && run.ate_refined_m >= 0.0) ate.Set("refined", run.ate_refined_m);
  if (refine && run.ate_refined_uncorrected_m >= 0.0) {
    ate.Set("refined_without_depth_correction", run.ate_refined_uncorrected_m);
  }
  return ate.empty() ? Json() : ate;
}

Json ConsistencyToJson(const PoseConsistency& c) {
  const auto six = [](const Vector6d& v) {
    return Json::ArrayOf(std::vector<double>(v.data(), v.data() + 6));
  };
  Json per_keyframe = Json::Array();
  for (const PoseConsistency::Pose& pose : c.per_pose) {
    per_keyframe.Push(Json::Object()
                          .Set("frame", pose.frame)
                          .Set("error", six(pose.error))
                          .Set("sigma", six(pose.sigma))
                          .Set("nees", pose.nees)
                          .Set("rotation_error_deg", pose.rotation_error_deg)
                          .Set("rotation_nees", pose.rotation_nees));
  }
  return Json::Object()
      .Set("keyframes", c.poses)
      .Set("inside_2sigma", c.inside_2sigma)
      .Set("inside_2sigma_per_axis",
           Json::ArrayOf(std::vector<double>(c.inside_2sigma_per_axis.begin(),
                                             c.inside_2sigma_per_axis.end())))
      .Set("median_error_over_sigma", c.median_error_over_sigma)
      .Set("mean_nees", c.mean_nees)
      .Set("nees_band", Json::ArrayOf(std::vector<double>{c.nees_band.first, c.nees_band.second}))
      .Set("median_rotation_error_deg", c.median_rotation_error_deg)
      .Set("mean_rotation_nees", c.mean_rotation_nees)
      .Set("rotation_nees_band", Json::ArrayOf(std::vector<double>{c.rotation_nees_band.first,
                                                                   c.rotation_nees_band.second}))
      .Set("per_keyframe", per_keyframe);
}

}  // namespace

std::vector<int> SourceIndices(const Dataset& dataset, const std::vector<int>& frames) {
  std::vector<int> indices;
  for (const int frame : frames) indices.push_back(dataset.info(frame).source_index);
  return indices;
}

std::string DescribeDecision(const SelectionDecision& d, const Dataset& dataset) {
  std::string line = "run: " + d.reason + ": candidates";
  char number[32];
  const std::vector<int> candidates = SourceIndices(dataset, d.candidates);
  for (size_t k = 0; k < candidates.size(); ++k) {
    line += (k == 0 ? " " : ",") + std::to_string(candidates[k]);
    if (k < d.gains.size()) {
      std::snprintf(number, sizeof(number), " (gain %.1f, map %.1f)", d.gains[k], d.map_gains[k]);
      line += number;
    }
  }
  line += " -> added";
  for (const int index : SourceIndices(dataset, d.added)) line += " " + std::to_string(index);
  return line;
}

namespace {

// The Q scales the gate gave the jointly tested frames: how many were scaled, and the
// scales' median, 90th percentile and largest.
Json NoiseScalesToJson(std::vector<double> scales) {
  Json json = Json::Object().Set("frames", static_cast<int>(scales.size()));
  if (scales.empty()) return json;
  std::sort(scales.begin(), scales.end());
  return json
      .Set("scaled", static_cast<int>(std::count_if(scales.begin(), scales.end(),
                                                    [](double s) { return s > 1.0; })))
      .Set("median", SortedQuantile(scales, 0.5))
      .Set("p90", SortedQuantile(scales, 0.9))
      .Set("max", scales.back());
}

Json GateToJson(const GateStatistics& gate) {
  return Json::Object()
      .Set("frames", gate.frames)
      .Set("tested", gate.tested)
      .Set("rejected", gate.rejected)
      .Set("rejected_joint", gate.rejected_joint)
      .Set("rejected_share", gate.rejected_share())
      .Set("incompatible_frames", gate.incompatible_frames)
      .Set("noise_scale", NoiseScalesToJson(gate.noise_scales));
}

Json WithdrawalToJson(const WithdrawalStatistics& withdrawal) {
  return Json::Object()
      .Set("tested", withdrawal.tested)
      .Set("withdrawn", withdrawal.withdrawn)
      .Set("rounds", withdrawal.rounds)
      .Set("still_failing", withdrawal.still_failing)
      .Set("put_back", withdrawal.put_back)
      .Set("cg_iterations", withdrawal.cg_iterations)
      .Set("seconds", withdrawal.seconds);
}

Json SavedMapToJson(const SavedMap& map) {
  int64_t keypoints = 0;
  for (const MapBaseFrame& b : map.base_frames) keypoints += b.features.size();
  return Json::Object()
      .Set("file", std::string(kMapDirectory) + "/" + kMapFileName)
      .Set("format_version", static_cast<int64_t>(kMapFormatVersion))
      .Set("poses", static_cast<int>(map.keyframes.size()))
      .Set("features", static_cast<int>(map.features.size()))
      .Set("features_pending", static_cast<int>(map.filter.pending.size()))
      .Set("keypoints", keypoints);
}

}  // namespace

Json RunReport(const Dataset& dataset, const RunOptions& options, const RunResult& run,
               double total_seconds, double outputs_seconds) {
  const PipelineResult& p = run.pipeline;
  const bool refine = options.pipeline.refine;
  Json report = Json::Object();
  report.Set("version", IeslamVersion())
      .Set("dataset", options.dataset)
      .Set("format", dataset.format())
      .Set("calibration", dataset.calibration_path())
      .Set("calibration_choice", Json::Object()
                                     .Set("chosen_by", dataset.calibration_chosen_by())
                                     .Set("source", dataset.calibration_source()))
      .Set("seed", static_cast<int64_t>(options.seed))
      .Set("options", options.ToJson())
      .Set("frames_total", dataset.size())
      .Set("frames_selected", static_cast<int>(p.selection.selected.size()));
  Json skipped = Json::Array();
  for (const auto& [frame, reason] : run.frames_skipped) {
    skipped.Push(Json::Object().Set("frame", frame).Set("reason", reason));
  }
  report.Set("frames_skipped", skipped)
      .Set("state_dim", p.filter->state_dim())
      .Set("poses", p.filter->num_poses())
      .Set("features", p.filter->num_features())
      .Set("features_pending", p.filter->num_pending_features())
      .Set("interrupted", run.interrupted())
      .Set("frames_processed", run.frames_processed());
  if (!run.continued_map_file.empty()) {
    report.Set("continued_map", Json::Object()
                                    .Set("file", run.continued_map_file)
                                    .Set("keyframes", run.map_frames)
                                    .Set("dataset_frames", dataset.size() - run.map_frames)
                                    .Set("load_seconds", run.map_load_seconds));
  }
  if (run.saved_map) report.Set("saved_map", SavedMapToJson(*run.saved_map));
  if (run.velocity_counts) report.Set("rolling_shutter", RollingShutterToJson(dataset, run));
  report.Set(
      "observation_gate",
      GateToJson(p.selection.gate).Set("withdrawal", WithdrawalToJson(p.selection.withdrawal)));
  // The dataset's warnings (printed when it was opened) and the run's, as printed.
  std::vector<std::string> warnings = dataset.warnings();
  warnings.insert(warnings.end(), run.warnings.begin(), run.warnings.end());
  report.Set("warnings", Json::ArrayOf(warnings));
  report.Set("seconds", SecondsToJson(run, refine, total_seconds, outputs_seconds));
  if (dataset.has_ground_truth()) {
    const Json ate = AteToJson(run, refine);
    if (ate.is_object()) report.Set("ate_rmse_m", ate);
    Json consistency = Json::Object();
    if (run.consistency_filter)
      consistency.Set("filter", ConsistencyToJson(*run.consistency_filter));
    if (run.consistency_refined) {
      consistency.Set("refined", ConsistencyToJson(*run.consistency_refined));
    }
    if (!consistency.empty()) report.Set("consistency", consistency);
  }
  if (refine) {
    // A failed or interrupted refinement compares nothing: null, with the reason beside it.
    report.Set("filter_vs_smoother",
               p.refinement && p.refinement->ok() ? RefinementToJson(*p.refinement) : Json());
    if (p.refinement && !p.refinement->ok()) report.Set("refinement_failed", p.refinement->failure);
  }
  if (p.has_estimate) report.Set("keyframe_sigmas", PoseSigmasToJson(p.estimate, run.timestamps));
  report.Set("decisions", DecisionsToJson(dataset, p.selection.decisions));
  return report;
}

}  // namespace ieslam
