#include "frontend/pairwise_evaluation.h"

#include <algorithm>
#include <cmath>
#include <deque>

#include "core/error.h"
#include "core/pose.h"

namespace ieslam {

const OptionTable<PairwiseOptions>& PairwiseOptions::Table() {
  static const OptionTable<PairwiseOptions>* table = [] {
    using O = PairwiseOptions;
    auto* t = new OptionTable<O>;
    t->Int("step", &O::step, "register frame i to frame i+K").Min(1);
    t->Int("min_inliers", &O::min_inliers, "inliers a successful pair needs").Min(3);
    t->Double("max_translation_error_m", &O::max_translation_error_m,
              "translation error a successful pair stays under")
        .Above(0.0);
    t->Double("max_rotation_error_deg", &O::max_rotation_error_deg,
              "rotation error a successful pair stays under")
        .Above(0.0);
    return t;
  }();
  return *table;
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double position = q / 100.0 * (values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(values.size() - 1, below + 1);
  return values[below] + (position - below) * (values[above] - values[below]);
}

void SummarisePairErrors(const std::vector<PairError>& pairs, PairErrorSummary* summary) {
  std::vector<double> rotation, translation;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), squares = Eigen::Vector3d::Zero();
  int successes = 0;
  for (const PairError& pair : pairs) {
    if (pair.success) {
      ++successes;
      sum += pair.translation_a;
      squares += pair.translation_a.cwiseAbs2();
    }
    if (!pair.compared) continue;
    rotation.push_back(pair.rotation_deg);
    translation.push_back(pair.translation_m);
  }
  summary->success_rate = pairs.empty() ? 0.0 : static_cast<double>(successes) / pairs.size();
  summary->rotation_error_median_deg = Percentile(rotation, 50);
  summary->translation_error_median_m = Percentile(translation, 50);
  summary->rotation_error_p90_deg = Percentile(rotation, 90);
  summary->translation_error_p90_m = Percentile(translation, 90);
  summary->translation_error_mean_a = Eigen::Vector3d::Zero();
  summary->translation_error_rms_a = Eigen::Vector3d::Zero();
  if (successes > 0) {
    summary->translation_error_mean_a = sum / successes;
    summary->translation_error_rms_a = (squares / successes).cwiseSqrt();
  }
}

PairwiseReport EvaluatePairwiseRegistration(const Dataset& dataset, const FrontendOptions& frontend,
                                            const PairwiseOptions& options,
                                            const std::function<void(int, int)>& progress,
                                            const std::function<bool()>& stop) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  if (!frontend.Check(&why)) throw ConfigError(why);
  const int n = dataset.size();
  if (n <= options.step) {
    throw DataError(dataset.directory() + ": " + std::to_string(n) +
                    " frames are too few for step " + std::to_string(options.step));
  }
  const FrameProcessor processor(dataset.rig(), frontend);
  PairwiseReport report;
  std::deque<ProcessedFrame> window;  // frames i .. i+K
  const int total_pairs = n - options.step;
  for (int j = 0; j < n; ++j) {
    if (stop && stop()) {
      report.interrupted = true;
      break;
    }
    window.push_back(processor.Process(dataset.Load(j)));
    if (static_cast<int>(window.size()) <= options.step) continue;
    const ProcessedFrame& a = window.front();
    const ProcessedFrame& b = window.back();
    PairRecord record;
    record.frame_a = a.info.source_index;  // as the user numbers frames (before --first)
    record.frame_b = b.info.source_index;
    if (!a.info.T_w_c_gt || !b.info.T_w_c_gt) {
      ++report.frames_without_ground_truth;
      window.pop_front();
      continue;
    }
    const FrameRegistration registration =
        RegisterFrames(a, b, frontend.matching, frontend.registration);
    record.matches = static_cast<int>(registration.matches.size());
    record.inliers = static_cast<int>(registration.result.inliers.size());
    record.frontend_seconds = b.seconds_extract + b.seconds_lift + registration.seconds_match +
                              registration.seconds_ransac;
    record.registered = registration.result.success;
    record.reason = registration.result.reason;
    if (record.registered) {
      const Eigen::Isometry3d T_a_b_gt = a.info.T_w_c_gt->inverse() * *b.info.T_w_c_gt;
      const Eigen::Isometry3d& T_a_b = registration.result.T_a_b;
      record.translation_error_a = T_a_b.translation() - T_a_b_gt.translation();
      record.translation_error_m = record.translation_error_a.norm();
      record.rotation_error_deg =
          RotationAngleBetween(T_a_b_gt.linear(), T_a_b.linear()) * 180.0 / M_PI;
      record.success = record.inliers >= options.min_inliers &&
                       record.translation_error_m < options.max_translation_error_m &&
                       record.rotation_error_deg < options.max_rotation_error_deg;
    }
    report.pairs.push_back(record);
    window.pop_front();
    if (progress) progress(static_cast<int>(report.pairs.size()), total_pairs);
  }
  if (report.pairs.empty() && !report.interrupted) {
    throw DataError(dataset.directory() + ": no frame pair has ground truth to compare with");
  }
  std::vector<PairError> errors;
  std::vector<double> ms;
  for (const PairRecord& record : report.pairs) {
    ms.push_back(record.frontend_seconds * 1000.0);
    errors.push_back({record.success, record.registered, record.translation_error_m,
                      record.rotation_error_deg, record.translation_error_a});
  }
  SummarisePairErrors(errors, &report);
  report.ms_per_frame = Percentile(ms, 50);
  return report;
}

}  // namespace ieslam
