#include "backend/evaluation/filter_smoother_comparison.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

namespace ieslam {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

double Mahalanobis(const Vector6d& d, const Matrix6d& P) {
  const Eigen::LLT<Matrix6d> llt(P);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(d.dot(llt.solve(d)));
}

// Of no values (e.g. Mahalanobis distances without the filter's covariances) the figures are
// null: a 0 would read as agreement.
Json StatsToJson(const ErrorStats& stats) {
  const double none = std::numeric_limits<double>::quiet_NaN();
  const bool any = stats.count > 0;
  return Json::Object()
      .Set("count", stats.count)
      .Set("rmse", any ? stats.rmse : none)
      .Set("mean", any ? stats.mean : none)
      .Set("max", any ? stats.max : none);
}

}  // namespace

FilterSmootherComparison CompareFilterToSmoother(const SlamEstimate& filter,
                                                 const SlamEstimate& smoother) {
  FilterSmootherComparison comparison;
  std::vector<double> translations, rotations, distances;
  double sum_squared = 0.0;
  int num_squared = 0;
  for (const auto& [frame_id, pose_f] : filter.poses) {
    const auto it = smoother.poses.find(frame_id);
    if (it == smoother.poses.end()) {
      ++comparison.frames_only_in_filter;
      continue;
    }
    const Vector6d& pose_s = it->second;
    FramePoseComparison frame;
    frame.frame_id = frame_id;
    frame.difference = PoseDifference(pose_f, pose_s);
    frame.translation_m = (pose_f.head<3>() - pose_s.head<3>()).norm();
    frame.rotation_deg = kRadToDeg * RotationAngleBetween(EulerZyxToRotation(pose_f.tail<3>()),
                                                          EulerZyxToRotation(pose_s.tail<3>()));
    const auto cov = filter.pose_covariances.find(frame_id);
    frame.mahalanobis = cov == filter.pose_covariances.end()
                            ? std::numeric_limits<double>::quiet_NaN()
                            : Mahalanobis(frame.difference, cov->second);
    if (std::isfinite(frame.mahalanobis)) {
      sum_squared += frame.mahalanobis * frame.mahalanobis;
      ++num_squared;
    }
    translations.push_back(frame.translation_m);
    rotations.push_back(frame.rotation_deg);
    distances.push_back(frame.mahalanobis);
    comparison.frames.push_back(frame);
  }
  for (const auto& [frame_id, pose] : smoother.poses) {
    if (filter.poses.count(frame_id) == 0) ++comparison.frames_only_in_smoother;
  }
  comparison.translation_m = ComputeFiniteErrorStats(translations);
  comparison.rotation_deg = ComputeFiniteErrorStats(rotations);
  comparison.mahalanobis = ComputeFiniteErrorStats(distances);
  comparison.mean_squared_mahalanobis =
      num_squared > 0 ? sum_squared / num_squared : std::numeric_limits<double>::quiet_NaN();

  std::vector<double> feature_distances;
  for (const auto& [feature_id, p_f] : filter.features) {
    const auto it = smoother.features.find(feature_id);
    if (it != smoother.features.end()) feature_distances.push_back((p_f - it->second).norm());
  }
  comparison.feature_m = ComputeFiniteErrorStats(feature_distances);
  return comparison;
}

Json ComparisonToJson(const FilterSmootherComparison& comparison, bool per_frame) {
  Json json = Json::Object();
  json.Set("num_frames", comparison.frames.size())
      .Set("frames_only_in_filter", comparison.frames_only_in_filter)
      .Set("frames_only_in_smoother", comparison.frames_only_in_smoother)
      .Set("translation_m", StatsToJson(comparison.translation_m))
      .Set("rotation_deg", StatsToJson(comparison.rotation_deg))
      .Set("mahalanobis", StatsToJson(comparison.mahalanobis))
      .Set("mean_squared_mahalanobis", comparison.mean_squared_mahalanobis)
      .Set("feature_m", StatsToJson(comparison.feature_m));
  if (per_frame) {
    Json frames = Json::Array();
    for (const FramePoseComparison& frame : comparison.frames) {
      Json difference = Json::Array();
      for (int i = 0; i < 6; ++i) difference.Push(frame.difference[i]);
      frames.Push(Json::Object()
                      .Set("frame_id", frame.frame_id)
                      .Set("translation_m", frame.translation_m)
                      .Set("rotation_deg", frame.rotation_deg)
                      .Set("mahalanobis", frame.mahalanobis)
                      .Set("difference", difference));
    }
    json.Set("frames", frames);
  }
  return json;
}

}  // namespace ieslam
