// Registration of frame i to frame i+K across a dataset, compared with ground truth: the
// check users run on their calibration and front-end settings (`ieslam register`).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/dataset.h"
#include "core/option_table.h"
#include "frontend/frame_processor.h"

namespace ieslam {

struct PairwiseOptions {
  int step = 5;  // K
  // A pair succeeds when registration returns a pose with at least `min_inliers` inliers
  // whose error against ground truth is below both limits.
  int min_inliers = 10;
  double max_translation_error_m = 0.05;
  double max_rotation_error_deg = 2.0;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<PairwiseOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

struct PairRecord {
  int frame_a = 0;
  int frame_b = 0;
  bool registered = false;  // the registrar returned a pose
  bool success = false;     // ... and it is within the error limits
  std::string reason;       // the registrar's refusal, when !registered
  int matches = 0;
  int inliers = 0;
  double translation_error_m = 0.0;
  double rotation_error_deg = 0.0;
  // The registered T_a_b's translation minus the ground truth's, in frame a's camera (x right,
  // y down, z along the optical axis).
  Eigen::Vector3d translation_error_a = Eigen::Vector3d::Zero();
  double frontend_seconds = 0.0;  // frame b's extraction + lifting + this pair's match + RANSAC
};

// The error figures of frame pairs compared with ground truth, whichever way they were
// registered.
struct PairErrorSummary {
  int frames_without_ground_truth = 0;
  double success_rate = 0.0;
  // Over the pairs with a pose to compare.
  double rotation_error_median_deg = 0.0;
  double translation_error_median_m = 0.0;
  double rotation_error_p90_deg = 0.0;
  double translation_error_p90_m = 0.0;
  // Along each axis of frame a's camera, over the successful pairs (a wrong registration
  // would swamp an axis): the error's mean, which shows a bias such as a calibration's, and
  // its RMS, which adds the spread.
  Eigen::Vector3d translation_error_mean_a = Eigen::Vector3d::Zero();
  Eigen::Vector3d translation_error_rms_a = Eigen::Vector3d::Zero();
  bool interrupted = false;  // `stop` ended the evaluation: the figures cover the pairs done
};

// One pair's part in a PairErrorSummary.
struct PairError {
  bool success = false;
  bool compared = false;  // it has a pose to compare with the ground truth
  double translation_m = 0.0;
  double rotation_deg = 0.0;
  Eigen::Vector3d translation_a = Eigen::Vector3d::Zero();
};

// Sets `summary`'s success rate over `pairs`, its medians and percentiles over those compared
// and its per-axis figures over the successful ones; leaves frames_without_ground_truth and
// interrupted as they are.
void SummarisePairErrors(const std::vector<PairError>& pairs, PairErrorSummary* summary);

struct PairwiseReport : PairErrorSummary {
  std::vector<PairRecord> pairs;
  // Median over pairs of frontend_seconds, in milliseconds.
  double ms_per_frame = 0.0;
};

// Processes every frame once (a sliding window of K+1 processed frames is kept) and
// registers i -> i+K. `progress` (optional) is called after each pair with (done, total);
// `stop` (optional) is polled before each frame, and when it returns true the report covers
// the pairs done so far.
PairwiseReport EvaluatePairwiseRegistration(const Dataset& dataset, const FrontendOptions& frontend,
                                            const PairwiseOptions& options,
                                            const std::function<void(int, int)>& progress = nullptr,
                                            const std::function<bool()>& stop = nullptr);

// Linear-interpolation percentile (numpy's default), q in [0, 100]; 0 for an empty list.
double Percentile(std::vector<double> values, double q);

}  // namespace ieslam
