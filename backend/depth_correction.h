// Self-calibration of a range imager's depth correction (RangeImager::depth_correction): the
// bundle adjustment of a problem's observations with the correction's three coefficients as
// parameters shared by every observation.
//
// Each observation's range is predicted as |p_c| DepthCorrectionFactor(x, y), (x, y) the
// normalised coordinates of the point in the range imager's frame (T_colour_range^-1 p_c):
// the range along the colour ray scales with the depth the imager read, to first order in the
// imager's offset from the colour camera (exactly when depth is registered to colour). The
// correction is observable where a feature is seen at different places in the image (a
// rotating camera); a global scale is not (it scales the whole map with the poses), which is
// why the model has no constant term.
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "backend/bundle_adjustment.h"
#include "core/camera.h"
#include "core/range_cloud.h"

namespace ieslam {

struct DepthCorrectionEstimate {
  // a, b, c of the depth as the problem's observations measured it (a correction already in
  // the calibration they were lifted with is not in these), and their covariance from the
  // Gauss-Newton information with the poses and features marginalised.
  std::array<double, 3> coefficients{};
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int observations = 0;  // those the solve used
  // 1/2 chi-square of those observations at the bundle adjustment's optimum (no correction,
  // no robust loss), and at the optimum with the correction; 0 when not solved.
  double cost_without = 0;
  double cost_with = 0;
  int iterations = 0;
  double seconds = 0.0;
  bool usable = false;  // solved, and the covariance positive definite
  bool interrupted = false;
  std::string failure;  // why not usable
};

// The correction that the observations of `problem` not rejected by `solved` (its bundle
// adjustment, whose poses and features are the start) imply, the anchor held fixed. `camera`
// is the pinhole the observations' (u, v) are in; T_colour_range places the range imager.
// Levenberg-Marquardt with `ba`'s iterations, function, gradient and parameter tolerances,
// first trust region, threads and stop; no robust loss and no rejection rounds (`solved`'s
// rejections stand for both).
DepthCorrectionEstimate EstimateDepthCorrection(const BundleAdjustmentProblem& problem,
                                                const BundleAdjustmentResult& solved,
                                                const PinholeCamera& camera,
                                                const Eigen::Isometry3d& T_colour_range,
                                                const BundleAdjustmentOptions& ba);

// `range` with `estimate` applied on top of its own correction: the factors multiply, and the
// product's quadratic terms beyond the model (a a' x^2 and the like, a few 1e-4 for
// corrections of a few per cent) are left out.
RangeImager WithDepthCorrection(const RangeImager& range, const DepthCorrectionEstimate& estimate);

// The factor 1 + a x + b y + c (x^2 + y^2) of `coefficients` (a, b, c) at the point p_r of the
// range imager's frame, (x, y) its normalised coordinates: how much a range read there exceeds
// the true one. The same for every point on p_r's ray.
double DepthCorrectionFactorAt(const Eigen::Vector3d& p_r,
                               const std::array<double, 3>& coefficients);

// The factor of `coefficients` at the point the observation o = (u, v, range) of `camera` saw,
// placed in the range imager by T_range_colour (the inverse of Rig::T_colour_range); 0 when
// that point is not in front of the imager.
double ObservedDepthCorrectionFactor(const FeatureObservation& o, const PinholeCamera& camera,
                                     const Eigen::Isometry3d& T_range_colour,
                                     const std::array<double, 3>& coefficients);

// `problem` as a range imager whose calibration held `coefficients` would have measured it:
// each observation's range (the filter's and the registered ones) divided by the factor at the
// point it observed ((u, v) in `camera` at that range, placed in the range imager by
// T_colour_range), and Q's range row and column by the same factor (the reading's noise is
// divided with it). An observation whose point is not in front of the range imager is kept
// as it is.
BundleAdjustmentProblem WithRangesCorrected(const BundleAdjustmentProblem& problem,
                                            const PinholeCamera& camera,
                                            const Eigen::Isometry3d& T_colour_range,
                                            const std::array<double, 3>& coefficients);

// Why `coefficients` are no correction to apply to `problem`: a coefficient, or the factor at
// one of its observations (ObservedDepthCorrectionFactor), beyond what a calibration allows
// (RangeImager::Check); empty when they are one.
std::string DepthCorrectionRefused(const BundleAdjustmentProblem& problem,
                                   const PinholeCamera& camera,
                                   const Eigen::Isometry3d& T_colour_range,
                                   const std::array<double, 3>& coefficients);

// `cloud` as the corrected range image would have given it: each point divided by the factor
// at it (along its ray; for a rolling shutter in the frame of the row it was read on), its
// normal turned with the surface (the inverse transpose of that map's Jacobian) and its range
// sigma divided by the factor. A point where the factor lies outside what a calibration allows
// (RangeImager::kMinDepthCorrectionFactor to kMaxDepthCorrectionFactor) is left out (invalid).
RangeCloud WithRangesCorrected(const RangeCloud& cloud, const std::array<double, 3>& coefficients);

}  // namespace ieslam
