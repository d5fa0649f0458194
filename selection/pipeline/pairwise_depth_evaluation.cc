#include "selection/pipeline/pairwise_depth_evaluation.h"

#include <cmath>
#include <deque>
#include <utility>

#include "core/error.h"
#include "core/pose.h"

namespace ieslam {
namespace {

struct WindowFrame {
  FrameInfo info;
  RangeCloud cloud;  // empty for a frame without ground truth, which is in no pair compared
};

// Frame b's cloud aligned onto frame a's from their ground-truth relative pose, compared with it
// in frame a's colour camera.
DepthPairRecord AlignPair(const WindowFrame& a, const WindowFrame& b, const Rig& rig,
                          const PairwiseOptions& options, const DepthAlignmentOptions& alignment) {
  DepthPairRecord record;
  record.frame_a = a.info.source_index;
  record.frame_b = b.info.source_index;
  const Eigen::Isometry3d T_a_b_gt = a.info.T_w_c_gt->inverse() * *b.info.T_w_c_gt;
  const Eigen::Isometry3d& T_c_r = rig.T_colour_range;
  const PairAlignment aligned =
      AlignRangeClouds(b.cloud, a.cloud, T_c_r.inverse() * T_a_b_gt * T_c_r, alignment);
  record.aligned = aligned.usable;
  record.reason = aligned.why_not;
  record.correspondences = aligned.correspondences;
  if (!record.aligned) return record;
  const Eigen::Isometry3d T_a_b = T_c_r * aligned.T_t_s * T_c_r.inverse();
  record.translation_error_a = T_a_b.translation() - T_a_b_gt.translation();
  record.translation_error_m = record.translation_error_a.norm();
  record.rotation_error_deg =
      RotationAngleBetween(T_a_b_gt.linear(), T_a_b.linear()) * 180.0 / M_PI;
  record.success = record.translation_error_m < options.max_translation_error_m &&
                   record.rotation_error_deg < options.max_rotation_error_deg;
  return record;
}

}  // namespace

DepthPairwiseReport EvaluatePairwiseDepthAlignment(const Dataset& dataset,
                                                   const PairwiseOptions& options,
                                                   const RangeCloudOptions& clouds,
                                                   const DepthAlignmentOptions& alignment,
                                                   const std::function<void(int, int)>& progress,
                                                   const std::function<bool()>& stop) {
  std::string why;
  if (!options.Check(&why) || !clouds.Check(&why) || !alignment.Check(&why)) {
    throw ConfigError(why);
  }
  const int n = dataset.size();
  if (n <= options.step) {
    throw DataError(dataset.directory() + ": " + std::to_string(n) +
                    " frames are too few for step " + std::to_string(options.step));
  }
  const Rig& rig = dataset.rig();
  const RangeRays rays(rig.range);
  DepthPairwiseReport report;
  std::deque<WindowFrame> window;  // frames i .. i+K
  const int total_pairs = n - options.step;
  for (int j = 0; j < n; ++j) {
    if (stop && stop()) {
      report.interrupted = true;
      break;
    }
    WindowFrame frame{dataset.info(j), RangeCloud()};
    if (frame.info.T_w_c_gt) {
      frame.cloud = MakeRangeCloud(dataset.Load(j).depth, rig.range, rig.T_colour_range, clouds,
                                   frame.info.depth_path, &rays);
    }
    window.push_back(std::move(frame));
    if (static_cast<int>(window.size()) <= options.step) continue;
    if (!window.front().info.T_w_c_gt || !window.back().info.T_w_c_gt) {
      ++report.frames_without_ground_truth;
    } else {
      report.pairs.push_back(AlignPair(window.front(), window.back(), rig, options, alignment));
      if (progress) progress(static_cast<int>(report.pairs.size()), total_pairs);
    }
    window.pop_front();
  }
  if (report.pairs.empty() && !report.interrupted) {
    throw DataError(dataset.directory() + ": no frame pair has ground truth to compare with");
  }
  std::vector<PairError> errors;
  for (const DepthPairRecord& record : report.pairs) {
    errors.push_back({record.success, record.aligned, record.translation_error_m,
                      record.rotation_error_deg, record.translation_error_a});
  }
  SummarisePairErrors(errors, &report);
  return report;
}

}  // namespace ieslam
