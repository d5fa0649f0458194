#include "apps/run_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

#include <glog/logging.h>
#include <opencv2/core.hpp>

#include "apps/app_util.h"
#include "apps/batch_refinement.h"
#include "apps/run_figures.h"
#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/filter_smoother_comparison.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

// Frames by their index in the dataset (before --first/--last/--stride), as
// selected_frames.txt and frames_skipped name them.
std::vector<int> SourceIndices(const Dataset& dataset, const std::vector<int>& frames) {
  std::vector<int> indices;
  for (const int frame : frames) indices.push_back(dataset.info(frame).source_index);
  return indices;
}

// One log line per selector decision, for --verbose; frames by their dataset index.
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

// Threads that load and process frames ahead of the selector: none in the deterministic
// single-thread mode, else one per core. The selector's own thread is not counted: it spends
// most of the run waiting for processed frames (with one worker on this 2-core machine it
// waited 14 of 20 s on 7scenes-dev), and its matching and filtering fit in the gaps. Two
// workers on 2 cores: 14.6-15.5 s against 19.6-20.9 s for one (500 frames, two runs each).
// More than a few only queue up behind the selector.
int PrefetchWorkers(int threads) {
  if (threads == 1) return 0;
  const int cores = threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency());
  return std::clamp(cores, 1, 3);
}

// One warning line per skipped frame (the first few; report.json lists them all), so that a
// bad image in the middle of a long sequence is seen without reading the report.
void WarnAboutSkippedFrames(const std::vector<std::pair<int, std::string>>& skipped) {
  constexpr size_t kShown = 10;
  for (size_t i = 0; i < skipped.size() && i < kShown; ++i) {
    std::fprintf(stderr, "run: warning: frame %d skipped: %s\n", skipped[i].first,
                 skipped[i].second.c_str());
  }
  if (skipped.size() > kShown) {
    std::fprintf(stderr, "run: warning: %zu more frames skipped (report.json: frames_skipped)\n",
                 skipped.size() - kShown);
  }
}

}  // namespace

bool RunOptions::Check(std::string* why) const {
  if (dataset.empty() || output.empty()) {
    if (why != nullptr) *why = "--dataset and --output are required";
    return false;
  }
  if (threads < 0) {
    if (why != nullptr) *why = "--threads must be >= 0";
    return false;
  }
  if (refine && selector.kind == SelectorKind::kDeadReckoning) {
    if (why != nullptr) {
      *why = "--refine needs a filter: not available with --selector deadreckoning";
    }
    return false;
  }
  return dataset_options.Check(why) && source.Check(why) && selector.Check(why) &&
         filter.Check(why) && map.Check(why) && range_cloud.Check(why) &&
         depth_alignment.Check(why);
}

Json SelectorOptionsToJson(const SelectorOptions& selector) {
  return Json::Object()
      .Set("kind", SelectorKindName(selector.kind))
      .Set("buffer", selector.buffer_size)
      .Set("interval", selector.interval)
      .Set("min_common_features", selector.min_common_features)
      .Set("map_gain_threshold", selector.map_gain_threshold)
      .Set("max_recovery_frames", selector.max_recovery_frames)
      .Set("min_view_change_deg", selector.min_view_change_deg);
}

Json FilterOptionsToJson(const InformationFilterOptions& filter) {
  return Json::Object()
      .Set("anchor_information", filter.anchor_information)
      .Set("iterative_recovery", filter.iterative_recovery)
      .Set("cg_tolerance", filter.cg_tolerance)
      .Set("max_dense_pose_dim", filter.max_dense_pose_dim);
}

RgbdSourceOptions RunOptions::SourceOptionsUsed() const {
  RgbdSourceOptions used = source;
  used.frontend.registration.seed = seed;
  used.database.seed = seed;
  used.prefetch.workers = PrefetchWorkers(threads);
  return used;
}

Json RunOptions::ToJson() const {
  const RgbdSourceOptions source = SourceOptionsUsed();
  const FeatureOptions& f = source.frontend.features;
  const LiftingOptions& l = source.frontend.lifting;
  const RegistrationOptions& r = source.frontend.registration;
  Json json = Json::Object();
  json.Set("dataset", DatasetOptionsToJson(dataset_options));
  json["features"]
      .Set("max_features", f.max_features)
      .Set("contrast_threshold", f.contrast_threshold)
      .Set("edge_threshold", f.edge_threshold)
      .Set("octave_layers", f.octave_layers)
      .Set("image_scale", f.image_scale);
  json["matching"]
      .Set("ratio", source.frontend.matching.ratio)
      .Set("mutual", source.frontend.matching.mutual);
  json["lifting"]
      .Set("window_radius", l.window_radius)
      .Set("sigma_multiplier", l.sigma_multiplier)
      .Set("footprint_multiplier", l.footprint_multiplier)
      .Set("edge_sigma_multiplier", l.edge_sigma_multiplier)
      .Set("min_valid_in_window", l.min_valid_in_window);
  json["registration"]
      .Set("inlier_threshold_m", r.inlier_threshold_m)
      .Set("max_iterations", r.max_iterations)
      .Set("probability", r.probability)
      .Set("min_inliers", r.min_inliers)
      .Set("min_spread_m", r.min_spread_m)
      .Set("inlier_chi2", r.inlier_chi2)
      .Set("use_point_covariances", r.use_point_covariances)
      .Set("seed", static_cast<int64_t>(r.seed));
  json["database"]
      .Set("trees", source.database.trees)
      .Set("checks", source.database.checks)
      .Set("neighbours", source.database.neighbours)
      .Set("ratio", source.database.ratio)
      .Set("seed", static_cast<int64_t>(source.database.seed));
  json["source"]
      .Set("max_base_candidates", source.max_base_candidates)
      .Set("max_new_features_per_frame", source.max_new_features_per_frame)
      .Set("min_inliers_secondary", source.min_inliers_secondary);
  json.Set("selector", SelectorOptionsToJson(selector));
  json.Set("filter", FilterOptionsToJson(filter));
  json["map"].Set("voxel_size_m", map.voxel_size_m).Set("pixel_step", map.pixel_step);
  json.Set("ba", BaOptionsToJson(ba));
  json.Set("depth_alignment", DepthAlignmentOptionsToJson(depth_alignment, range_cloud));
  json.Set("threads", threads);
  return json;
}

RunSummary RunPipeline(const RunOptions& options, const std::function<bool()>& stop) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  const auto start = std::chrono::steady_clock::now();
  // OpenCV's TBB back end warns on stderr when asked for more threads than there are cores.
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  if (options.threads > 0) cv::setNumThreads(std::min(options.threads, cores));
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  PrepareOutputDirectory(options.output);

  RgbdFrameSource source(*dataset, options.SourceOptionsUsed());
  InformationFilter filter(options.filter, dataset->rig().colour);
  Progress progress("run", dataset->size(), options.quiet);
  const SelectionResult selection =
      KeyframeSelector(options.selector)
          .Run(
              &source, &filter,
              [&progress](int done, int selected) {
                progress.Update(done, std::to_string(selected) + " selected");
              },
              stop,
              [&options, &dataset](const SelectionDecision& d) {
                if (options.verbose)
                  std::fprintf(stderr, "%s\n", DescribeDecision(d, *dataset).c_str());
              });
  progress.Finish();

  // Trajectories.
  const auto poses = KeyframeSelector::FramePoses(selection, filter);
  Trajectory keyframes, trajectory;
  for (int frame : selection.selected) {
    if (poses[frame]) keyframes.push_back({dataset->info(frame).timestamp, *poses[frame]});
  }
  std::sort(keyframes.begin(), keyframes.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.timestamp < b.timestamp; });
  RunSummary summary;
  summary.interrupted = selection.interrupted;
  summary.frames_processed = selection.frames_processed;
  for (int f = 0; f < selection.frames_processed; ++f) {
    if (poses[f]) {
      trajectory.push_back({dataset->info(f).timestamp, *poses[f]});
    } else {
      summary.frames_skipped.emplace_back(dataset->info(f).source_index,
                                          selection.frames[f].skip_reason);
    }
  }
  WarnAboutSkippedFrames(summary.frames_skipped);
  const std::string out = options.output;
  WriteTumTrajectory(JoinPath(out, "keyframes.tum"), keyframes,
                     "ieslam keyframes (filter estimate)");
  WriteTumTrajectory(JoinPath(out, "trajectory.tum"), trajectory, "ieslam every processed frame");
  std::string selected_lines;
  for (int frame : selection.selected) {
    char line[64];
    std::snprintf(line, sizeof(line), "%d %.6f\n", dataset->info(frame).source_index,
                  dataset->info(frame).timestamp);
    selected_lines += line;
  }
  WriteTextAtomically(JoinPath(out, "selected_frames.txt"), selected_lines);
  if (dataset->has_ground_truth()) {
    WriteTumTrajectory(JoinPath(out, "groundtruth.tum"), dataset->GroundTruth(), "ground truth");
  }
  const bool has_gt = dataset->has_ground_truth();
  if (has_gt) {
    summary.ate_keyframes_m =
        AteOfFiles(JoinPath(out, "groundtruth.tum"), JoinPath(out, "keyframes.tum"));
    summary.ate_trajectory_m =
        AteOfFiles(JoinPath(out, "groundtruth.tum"), JoinPath(out, "trajectory.tum"));
  }

  // The bundle-adjustment problem (the selected poses and features as the filter estimates
  // them, with the observations and Q it used), written so that `ieslam refine` can refine
  // this run again later; with --refine, refined now.
  Json comparison, pose_sigmas;
  double ba_seconds = 0.0, covariance_seconds = 0.0;
  CHECK(!options.refine || selection.chained_T_w_c.empty())
      << "RunOptions::Check passed --refine without a filter";
  if (selection.chained_T_w_c.empty() && filter.num_poses() > 0) {
    StoredBaProblem stored;
    stored.problem = MakeProblemFromFilter(filter, selection.observations);
    stored.camera = dataset->rig().colour;
    for (const auto& [frame, T] : stored.problem.T_w_c) {
      stored.timestamps[frame] = dataset->info(frame).timestamp;
    }
    WriteBaProblem(JoinPath(out, "ba_problem.txt"), stored);
    WriteInformationBlocks(filter, JoinPath(out, "information_blocks.txt"));
    const auto covariance_start = std::chrono::steady_clock::now();
    const SlamEstimate estimate = FilterEstimate(filter);
    covariance_seconds = SecondsSince(covariance_start);
    pose_sigmas = PoseSigmasToJson(estimate, stored.timestamps);
    if (options.refine) {
      BundleAdjustmentOptions ba = options.ba;
      if (options.threads > 0) ba.num_threads = options.threads;
      DepthRefinement depth;
      depth.options = options.depth_alignment;
      // Pairs align independently: any number of threads gives the same constraints.
      depth.options.num_threads = options.threads > 0 ? options.threads : cores;
      if (depth.options.rounds > 0) {
        depth.clouds =
            LoadRangeClouds(*dataset, stored, options.range_cloud, "run", &depth.frames_left_out);
      }
      const RefinementOutcome refined =
          RefineToFiles(stored, estimate, ba, out,
                        has_gt ? JoinPath(out, "groundtruth.tum") : std::string(), &depth);
      ba_seconds = refined.seconds;
      summary.ate_refined_m = refined.ate_refined_m;
      comparison = refined.comparison;
    }
  }

  // The dense map: the selected frames' clouds at their estimated poses.
  if (options.write_map) {
    DenseMap map(options.map);
    for (int frame : selection.selected) {
      if (poses[frame]) map.AddFrame(dataset->Load(frame), dataset->rig(), *poses[frame]);
    }
    map.WritePly(JoinPath(out, "map.ply"));
  }

  // The report.
  summary.frames_total = dataset->size();
  summary.frames_selected = static_cast<int>(selection.selected.size());
  summary.state_dim = filter.state_dim();
  Json report = Json::Object();
  report.Set("version", IESLAM_VERSION)
      .Set("dataset", options.dataset)
      .Set("format", dataset->format())
      .Set("calibration", dataset->calibration_path())
      .Set("seed", static_cast<int64_t>(options.seed))
      .Set("options", options.ToJson())
      .Set("frames_total", summary.frames_total)
      .Set("frames_selected", summary.frames_selected);
  Json skipped = Json::Array();
  for (const auto& [frame, reason] : summary.frames_skipped) {
    skipped.Push(Json::Object().Set("frame", frame).Set("reason", reason));
  }
  report.Set("frames_skipped", skipped)
      .Set("state_dim", summary.state_dim)
      .Set("poses", filter.num_poses())
      .Set("features", filter.num_features())
      .Set("interrupted", summary.interrupted)
      .Set("frames_processed", summary.frames_processed);
  const SourceTimings& t = source.timings();
  report["seconds"]
      .Set("total", SecondsSince(start))
      .Set("frontend", t.total())
      .Set("selection", std::max(0.0, selection.seconds_selection - t.caller()))
      .Set("filter", selection.seconds_filter)
      .Set("load", t.load_s);
  report["seconds"].Set("covariance", covariance_seconds);
  report["seconds"]["frontend_stages"]
      .Set("load", t.load_s)
      .Set("extract", t.extract_s)
      .Set("lift", t.lift_s)
      .Set("match", t.match_s)
      .Set("ransac", t.ransac_s)
      .Set("fetch_wall", t.fetch_wall_s);
  if (options.refine) report["seconds"].Set("ba", ba_seconds);
  if (has_gt) {
    Json ate = Json::Object();  // only what could be computed; absent when nothing could
    if (summary.ate_keyframes_m >= 0.0) ate.Set("keyframes", summary.ate_keyframes_m);
    if (summary.ate_trajectory_m >= 0.0) ate.Set("trajectory", summary.ate_trajectory_m);
    if (options.refine && summary.ate_refined_m >= 0.0) ate.Set("refined", summary.ate_refined_m);
    if (!ate.empty()) report.Set("ate_rmse_m", ate);
  }
  if (options.refine) report.Set("filter_vs_smoother", comparison);
  if (pose_sigmas.is_array()) report.Set("keyframe_sigmas", pose_sigmas);
  Json decisions = Json::Array();
  for (const SelectionDecision& d : selection.decisions) {
    decisions.Push(Json::Object()
                       .Set("candidates", Json::ArrayOf(SourceIndices(*dataset, d.candidates)))
                       .Set("gains", Json::ArrayOf(d.gains))
                       .Set("map_gains", Json::ArrayOf(d.map_gains))
                       .Set("added", Json::ArrayOf(SourceIndices(*dataset, d.added)))
                       .Set("reason", d.reason));
  }
  report.Set("decisions", decisions);
  WriteTextAtomically(JoinPath(out, "report.json"), report.Dump() + "\n");
  summary.report = report;
  return summary;
}

}  // namespace ieslam
