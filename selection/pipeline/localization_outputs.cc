#include "selection/pipeline/localization_outputs.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "backend/evaluation/error_stats.h"
#include "backend/evaluation/evaluation.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/stopwatch.h"
#include "core/trajectory.h"
#include "core/version.h"

namespace ieslam {
namespace {

// The data's length: the processed frames' span, plus one frame period (n frames cover n).
double DataSeconds(const LocalizeResult& result) {
  if (result.frames.size() < 2) return 0.0;
  const double span = result.frames.back().timestamp - result.frames.front().timestamp;
  return span * static_cast<double>(result.frames.size()) /
         static_cast<double>(result.frames.size() - 1);
}

Json StatsJson(const std::vector<double>& values) {
  Json json = Json::Object();
  if (values.empty()) return json;
  const ErrorStats s = ComputeErrorStats(values);
  json.Set("median", s.median).Set("min", s.min).Set("max", s.max).Set("mean", s.mean);
  return json;
}

}  // namespace

LocalizeEvaluation EvaluateLocalization(const Dataset& dataset, const LocalizeResult& result,
                                        const MapFrameAlignment& alignment) {
  LocalizeEvaluation out;
  if (!alignment.ok) {
    out.reason = alignment.reason;
    return out;
  }
  if (!dataset.has_ground_truth()) {
    out.reason = "the dataset has no ground truth";
    return out;
  }
  std::vector<Eigen::Vector3d> p_est, p_gt;
  std::vector<double> errors;
  int inside = 0, axes = 0;
  double nees = 0.0;
  for (const LocalizedFrame& f : result.frames) {
    const auto& gt = dataset.info(f.frame).T_w_c_gt;
    if (!f.localized || !gt) continue;
    const Eigen::Vector3d p = (alignment.T_map_gt * *gt).translation();
    const Eigen::Vector3d e = f.T_map_c.translation() - p;
    p_est.push_back(f.T_map_c.translation());
    p_gt.push_back(p);
    errors.push_back(e.norm());
    if (!alignment.has_origin) continue;
    // Against the covariance, the error where the map's covariances have their origin.
    const Eigen::Vector3d e0 =
        f.T_map_c.translation() - (alignment.T_map_gt_origin * *gt).translation();
    const Eigen::Matrix3d P = f.covariance.topLeftCorner<3, 3>();
    for (int k = 0; k < 3; ++k) {
      ++axes;
      if (std::abs(e0[k]) <= 2.0 * std::sqrt(P(k, k))) ++inside;
    }
    nees += e0.dot(P.ldlt().solve(e0));
  }
  out.pairs = static_cast<int>(errors.size());
  if (errors.empty()) {
    out.reason = "no localised frame has ground truth";
    return out;
  }
  const ErrorStats s = ComputeErrorStats(errors);
  out.ok = true;
  out.ate_map_frame_m = s.rmse;
  out.median_m = s.median;
  out.max_m = s.max;
  if (axes > 0) {
    out.has_consistency = true;
    out.inside_2sigma = static_cast<double>(inside) / axes;
    out.mean_position_nees = nees / static_cast<double>(axes / 3);
  }
  if (p_est.size() >= 3) {
    const Eigen::Isometry3d T = AlignHorn(p_est, p_gt);
    double sum = 0.0;
    for (size_t i = 0; i < p_est.size(); ++i) sum += (T * p_est[i] - p_gt[i]).squaredNorm();
    out.ate_aligned_m = std::sqrt(sum / static_cast<double>(p_est.size()));
    out.has_ate_aligned = true;
  }
  return out;
}

Json LocalizeReport(const Dataset& dataset, const std::string& map_dir, const SavedMap& map,
                    const RunOptions& options, const LocalizeResult& result,
                    const MapFrameAlignment& alignment, const LocalizeEvaluation& evaluation,
                    double seconds_load_map, double seconds_outputs) {
  Json report = Json::Object();
  report.Set("version", IeslamVersion()).Set("command", "localize").Set("dataset", options.dataset);
  Json& m = report["map"];
  m.Set("dir", map_dir).Set("made_by", map.version).Set("made_from", map.dataset);
  m.Set("keyframes", map.keyframes.size()).Set("features", map.features.size());
  m.Set("poses", result.refined_poses ? "refined" : "filter");
  report.Set("seed", static_cast<int64_t>(options.seed)).Set("options", options.ToJson());
  const int total = static_cast<int>(result.frames.size());
  report.Set("frames_total", dataset.size()).Set("frames_processed", total);
  report.Set("frames_localized", result.localized);
  report.Set("localized_share", total > 0 ? static_cast<double>(result.localized) / total : 0.0);
  report.Set("frames_localized_by_map", result.localized_by_map);
  report.Set("localized_by_map_share",
             total > 0 ? static_cast<double>(result.localized_by_map) / total : 0.0);
  report.Set("resumptions", result.resumptions);
  report.Set("database_queries", result.database_queries);
  if (result.velocity_counts) {
    report.Set("rolling_shutter",
               Json::Object()
                   .Set("readout_s", dataset.rig().colour_readout_s)
                   .Set("velocity_from_both_neighbours", result.velocity_counts->both)
                   .Set("velocity_from_one_neighbour", result.velocity_counts->one)
                   .Set("no_velocity", result.velocity_counts->none));
  }
  Json not_placed = Json::Array();
  std::vector<double> inliers, features, sigmas;
  for (const LocalizedFrame& f : result.frames) {
    if (!f.localized) {
      Json entry = Json::Object();
      entry.Set("frame", dataset.info(f.frame).source_index).Set("reason", f.reason);
      not_placed.Push(entry);
      continue;
    }
    inliers.push_back(f.inliers);
    features.push_back(f.map_features);
    sigmas.push_back(std::sqrt(f.covariance.topLeftCorner<3, 3>().trace()));
  }
  report.Set("frames_not_localized", not_placed);
  report.Set("interrupted", result.interrupted);
  report.Set("inliers", StatsJson(inliers)).Set("map_feature_inliers", StatsJson(features));
  report.Set("position_sigma_m", StatsJson(sigmas));

  Json& gt = report["ground_truth"];
  gt.Set("map_keyframes", alignment.keyframes);
  if (alignment.ok) gt.Set("map_keyframes_rmse_m", alignment.rmse_m);
  if (evaluation.ok) {
    gt.Set("pairs", evaluation.pairs);
    Json& ate = report["ate_rmse_m"];
    ate.Set("map_frame", evaluation.ate_map_frame_m);
    if (evaluation.has_ate_aligned) ate.Set("aligned", evaluation.ate_aligned_m);
    gt.Set("median_m", evaluation.median_m).Set("max_m", evaluation.max_m);
    Json& c = report["consistency"];
    if (evaluation.has_consistency) {
      c.Set("inside_2sigma", evaluation.inside_2sigma);
      c.Set("mean_position_nees", evaluation.mean_position_nees);
    } else {
      c.Set("none",
            "the map's first keyframe has no ground truth, where its covariances have "
            "their origin");
    }
  } else {
    gt.Set("none", evaluation.reason);
  }

  Json& s = report["seconds"];
  const LocalizeTimings& t = result.seconds;
  const double total_s = seconds_load_map + t.total + seconds_outputs;
  s.Set("total", total_s).Set("load_map", seconds_load_map).Set("setup", t.setup);
  s.Set("frontend", t.fetch_wall).Set("match", t.match).Set("ransac", t.ransac);
  s.Set("outputs", seconds_outputs);
  Json& work = s["worker_sums"];
  work.Set("load", t.load).Set("extract", t.extract).Set("lift", t.lift);
  const double data_s = DataSeconds(result);
  if (data_s > 0.0 && total_s > 0.0) report.Set("real_time_factor", data_s / total_s);
  return report;
}

const std::vector<std::string>& LocalizeOutputNames() {
  static const std::vector<std::string> names = {"trajectory.tum", "covariances.txt", "frames.txt",
                                                 "groundtruth.tum", "report.json"};
  return names;
}

LocalizeEvaluation WriteLocalizeOutputs(const std::string& out, const Dataset& dataset,
                                        const std::string& map_dir, const SavedMap& map,
                                        const RunOptions& options, const LocalizeResult& result,
                                        const MapFrameAlignment& alignment,
                                        double seconds_load_map) {
  const auto start = std::chrono::steady_clock::now();
  RemoveStaleTempFiles(out, LocalizeOutputNames());
  for (const std::string& name : LocalizeOutputNames()) {
    std::error_code ec;
    std::filesystem::remove(JoinPath(out, name), ec);
    if (ec) throw OutputError("cannot remove " + JoinPath(out, name) + ": " + ec.message());
  }
  Trajectory trajectory, ground_truth;
  for (const LocalizedFrame& f : result.frames) {
    if (!f.localized) continue;
    trajectory.push_back({f.timestamp, f.T_map_c});
    const auto& gt = dataset.info(f.frame).T_w_c_gt;
    if (alignment.ok && gt) ground_truth.push_back({f.timestamp, alignment.T_map_gt * *gt});
  }
  WriteTumTrajectory(JoinPath(out, "trajectory.tum"), trajectory,
                     "ieslam localize: localised frames, in the map's frame");
  WriteFileAtomically(JoinPath(out, "covariances.txt"), [&](std::ostream& os) {
    os << "# ieslam localize: timestamp, then the 6x6 covariance of (x y z alpha beta gamma) of "
          "each localised frame, row by row\n";
    char buffer[32];
    for (const LocalizedFrame& f : result.frames) {
      if (!f.localized) continue;
      std::snprintf(buffer, sizeof(buffer), "%.6f", f.timestamp);
      os << buffer;
      for (int r = 0; r < 6; ++r) {
        for (int c = 0; c < 6; ++c) {
          std::snprintf(buffer, sizeof(buffer), " %.9g", f.covariance(r, c));
          os << buffer;
        }
      }
      os << "\n";
    }
  });
  WriteFileAtomically(JoinPath(out, "frames.txt"), [&](std::ostream& os) {
    os << "# ieslam localize: frame timestamp placed(map|tracking|no) inliers map_inliers "
          "map_features base_keyframe_frame\n";
    char buffer[160];
    for (const LocalizedFrame& f : result.frames) {
      const char* placed = !f.localized ? "no" : f.by_map ? "map" : "tracking";
      const int base = f.base_keyframe >= 0 ? map.keyframes[f.base_keyframe].frame : -1;
      std::snprintf(buffer, sizeof(buffer), "%d %.6f %s %d %d %d %d\n",
                    dataset.info(f.frame).source_index, f.timestamp, placed, f.inliers,
                    f.map_inliers, f.map_features, base);
      os << buffer;
    }
  });
  if (!ground_truth.empty()) {
    WriteTumTrajectory(JoinPath(out, "groundtruth.tum"), ground_truth,
                       "ieslam localize: ground truth in the map's frame, at localised frames");
  }
  const LocalizeEvaluation evaluation = EvaluateLocalization(dataset, result, alignment);
  const double seconds_outputs = SecondsSince(start);
  const Json report = LocalizeReport(dataset, map_dir, map, options, result, alignment, evaluation,
                                     seconds_load_map, seconds_outputs);
  WriteTextAtomically(JoinPath(out, "report.json"), report.Dump() + "\n");
  return evaluation;
}

}  // namespace ieslam
