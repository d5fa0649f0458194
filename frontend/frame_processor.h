// One frame through the front end: SIFT in the colour image, keypoints lifted to 3-D
// through the range image; and the registration of two processed frames (match ->
// RANSAC). Only keypoints that lifted are kept: the filter's observations are (u, v, d).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/camera.h"
#include "core/dataset.h"
#include "frontend/features.h"
#include "frontend/lifting.h"
#include "frontend/matcher.h"
#include "frontend/registration.h"

namespace ieslam {

struct FrontendOptions {
  FeatureOptions features;
  LiftingOptions lifting;
  MatchOptions matching;
  RegistrationOptions registration;

  bool Check(std::string* why) const;
};

struct ProcessedFrame {
  FrameInfo info;
  FrameFeatures features;           // lifted keypoints only; row i <-> points[i]
  std::vector<LiftedPoint> points;  // all valid
  int keypoints_detected = 0;
  double seconds_extract = 0.0;
  double seconds_lift = 0.0;
};

class FrameProcessor {
 public:
  // Throws ConfigError for options failing Check() or a rig failing Rig::Check().
  FrameProcessor(const Rig& rig, const FrontendOptions& options);

  ProcessedFrame Process(const Frame& frame) const;

  const FrontendOptions& options() const { return options_; }

 private:
  FrontendOptions options_;
  FeatureLifter lifter_;
};

struct FrameRegistration {
  RegistrationResult result;             // T_a_b: p_a = T_a_b * p_b, in colour camera frames
  std::vector<DescriptorMatch> matches;  // query = frame b, train = frame a
  double seconds_match = 0.0;
  double seconds_ransac = 0.0;
};

// Registers frame b onto frame a.
FrameRegistration RegisterFrames(const ProcessedFrame& a, const ProcessedFrame& b,
                                 const MatchOptions& matching,
                                 const RegistrationOptions& registration);

// The motion T_a_b of one step between consecutive frames (a rolling-shutter frame's velocity
// comes from these), or nullopt when either frame has no features or the registration fails.
// The match and RANSAC seconds are added to *match_s and *ransac_s.
std::optional<Eigen::Isometry3d> StepMotion(const ProcessedFrame& a, const ProcessedFrame& b,
                                            const FrontendOptions& frontend, double* match_s,
                                            double* ransac_s);

}  // namespace ieslam
