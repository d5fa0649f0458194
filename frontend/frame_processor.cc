#include "frontend/frame_processor.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <glog/logging.h>

#include "core/error.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

// `options`, once they pass Check(): the lifter they configure is built after this.
const FrontendOptions& Checked(const FrontendOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  return options;
}

}  // namespace

bool FrontendOptions::Check(std::string* why) const {
  return features.Check(why) && lifting.Check(why) && matching.Check(why) &&
         registration.Check(why);
}

FrameProcessor::FrameProcessor(const Rig& rig, const FrontendOptions& options)
    : options_(Checked(options)), lifter_(rig, options.lifting) {}

ProcessedFrame FrameProcessor::Process(const Frame& frame) const {
  ProcessedFrame processed;
  processed.info = frame.info;
  auto start = std::chrono::steady_clock::now();
  FrameFeatures all = ExtractFeatures(frame.colour, options_.features);
  processed.seconds_extract = SecondsSince(start);
  processed.keypoints_detected = all.size();

  start = std::chrono::steady_clock::now();
  std::vector<LiftedPoint> lifted = lifter_.Lift(all.pixels, frame.depth);
  std::vector<int> keep;
  for (int i = 0; i < all.size(); ++i) {
    if (lifted[i].valid) keep.push_back(i);
  }
  FrameFeatures& kept = processed.features;
  // Base frames keep these to the end of the selection: sized exactly, not grown.
  kept.pixels.reserve(keep.size());
  kept.scales.reserve(keep.size());
  kept.colours.reserve(keep.size());
  processed.points.reserve(keep.size());
  kept.descriptors.create(static_cast<int>(keep.size()), all.descriptors.cols,
                          all.descriptors.type());
  for (size_t row = 0; row < keep.size(); ++row) {
    const int i = keep[row];
    kept.pixels.push_back(all.pixels[i]);
    kept.scales.push_back(all.scales[i]);
    kept.colours.push_back(all.colours[i]);
    all.descriptors.row(i).copyTo(kept.descriptors.row(static_cast<int>(row)));
    processed.points.push_back(lifted[i]);
  }
  processed.seconds_lift = SecondsSince(start);
  return processed;
}

FrameRegistration RegisterFrames(const ProcessedFrame& a, const ProcessedFrame& b,
                                 const MatchOptions& matching,
                                 const RegistrationOptions& registration) {
  FrameRegistration out;
  auto start = std::chrono::steady_clock::now();
  out.matches = MatchDescriptors(b.features.descriptors, a.features.descriptors, matching);
  out.seconds_match = SecondsSince(start);

  start = std::chrono::steady_clock::now();
  std::vector<Eigen::Vector3d> points_a, points_b;
  std::vector<Eigen::Matrix3d> covariances_a, covariances_b;
  std::vector<double> sigmas;
  points_a.reserve(out.matches.size());
  points_b.reserve(out.matches.size());
  for (const DescriptorMatch& m : out.matches) {
    points_a.push_back(a.points[m.train].p_c);
    points_b.push_back(b.points[m.query].p_c);
    if (registration.use_point_covariances) {
      covariances_a.push_back(a.points[m.train].p_c_covariance);
      covariances_b.push_back(b.points[m.query].p_c_covariance);
    }
    sigmas.push_back(std::sqrt(a.points[m.train].Q(2, 2) + b.points[m.query].Q(2, 2)));
  }
  RegistrationOptions options = registration;
  if (!sigmas.empty()) {
    std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
    options.inlier_threshold_m = std::max(options.inlier_threshold_m,
                                          options.inlier_noise_sigmas * sigmas[sigmas.size() / 2]);
  }
  out.result = options.use_point_covariances
                   ? RegisterPointSets(points_a, points_b, covariances_a, covariances_b, options)
                   : RegisterPointSets(points_a, points_b, options);
  out.seconds_ransac = SecondsSince(start);
  return out;
}

std::optional<Eigen::Isometry3d> StepMotion(const ProcessedFrame& a, const ProcessedFrame& b,
                                            const FrontendOptions& frontend, double* match_s,
                                            double* ransac_s) {
  if (a.features.size() == 0 || b.features.size() == 0) return std::nullopt;
  const FrameRegistration step = RegisterFrames(a, b, frontend.matching, frontend.registration);
  *match_s += step.seconds_match;
  *ransac_s += step.seconds_ransac;
  if (!step.result.success) return std::nullopt;
  return step.result.T_a_b;
}

}  // namespace ieslam
