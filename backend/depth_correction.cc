#include "backend/depth_correction.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <ceres/ceres.h>
#include <ceres/covariance.h>
#include <Eigen/Cholesky>

#include "backend/ba_parameters.h"
#include "backend/ba_residuals.h"
#include "backend/pose_covariance.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

using ba_internal::Parameters;

// UvdResidual's (u, v, d) with the range scaled by the correction's factor at the point's
// place in the range imager: UvdResidual's whitened error W e plus W's range column times what
// the factor adds to the range, |p_c| (factor - 1).
class CorrectedUvdResidual {
 public:
  CorrectedUvdResidual(const PinholeCamera& camera, const Eigen::Isometry3d& T_range_colour,
                       const Eigen::Vector3d& z, const Eigen::Matrix3d& sqrt_information,
                       double min_depth_m)
      : uvd_(camera, z, sqrt_information, min_depth_m),
        R_rc_(T_range_colour.linear()),
        t_rc_(T_range_colour.translation()),
        W_range_(sqrt_information.col(2)),
        min_depth_m_(min_depth_m) {}

  template <typename T>
  bool operator()(const T* q_w_c_ptr, const T* t_w_c_ptr, const T* p_w_ptr, const T* k,
                  T* residual) const {
    if (!uvd_(q_w_c_ptr, t_w_c_ptr, p_w_ptr, residual)) return false;
    const Eigen::Map<const Eigen::Quaternion<T>> q_w_c(q_w_c_ptr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_w_c(t_w_c_ptr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_w(p_w_ptr);
    const Eigen::Matrix<T, 3, 1> p_c =
        q_w_c.normalized().toRotationMatrix().transpose() * (p_w - t_w_c);
    const Eigen::Matrix<T, 3, 1> p_r = R_rc_.cast<T>() * p_c + t_rc_.cast<T>();
    if (!(p_r[2] > T(min_depth_m_))) return false;
    const T x = p_r[0] / p_r[2], y = p_r[1] / p_r[2];
    const T added = k[0] * x + k[1] * y + k[2] * (x * x + y * y);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r += W_range_.cast<T>() * (p_c.norm() * added);
    return true;
  }

 private:
  UvdResidual uvd_;
  Eigen::Matrix3d R_rc_;
  Eigen::Vector3d t_rc_;
  Eigen::Vector3d W_range_;  // the whitening's range column
  double min_depth_m_;
};

// Stops the solve when the caller's stop says so, and remembers that it did.
class StopCallback final : public ceres::IterationCallback {
 public:
  explicit StopCallback(const std::function<bool()>& stop) : stop_(stop) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    fired_ = fired_ || (stop_ && stop_());
    return fired_ ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }
  bool fired() const { return fired_; }

 private:
  const std::function<bool()>& stop_;
  bool fired_ = false;
};

// The estimate's covariance: the Schur complement over the free poses and the coefficients,
// the features eliminated, inverted for the coefficients' columns.
bool CoefficientCovariance(ceres::Problem* problem, Parameters* params, int anchor_id, double* k,
                           const std::set<int>& frames, const std::set<int64_t>& features,
                           int num_threads, Eigen::Matrix3d* covariance) {
  std::vector<double*> leading;
  for (const int frame_id : frames) {
    if (frame_id == anchor_id) continue;
    leading.push_back(params->t_w_c(frame_id));
    leading.push_back(params->q_w_c(frame_id));
  }
  leading.push_back(k);
  std::vector<double*> feature_blocks;
  for (const int64_t feature_id : features) feature_blocks.push_back(params->p_w(feature_id));
  Eigen::MatrixXd S;
  if (!LeadingSchurComplement(problem, leading, feature_blocks, num_threads, &S)) return false;
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) return false;
  const int n = static_cast<int>(S.rows());
  const Eigen::MatrixXd columns = llt.solve(Eigen::MatrixXd::Identity(n, n).rightCols(3));
  *covariance = columns.bottomRows(3);
  return covariance->allFinite();
}

// Adds the observations not `rejected` whose pose and feature `params` hold to `problem`, each
// with the coefficients' block `k`; the poses' quaternions on `manifold`, the features first
// in `ordering` (eliminated) and the poses and `k` after. Returns how many it added.
int AddObservations(const std::vector<BundleAdjustmentObservation>& observations,
                    const std::set<std::pair<int, int64_t>>& rejected, const PinholeCamera& camera,
                    const Eigen::Isometry3d& T_range_colour, double min_depth_m, Parameters* params,
                    double* k, ceres::Manifold* manifold, ceres::Problem* problem,
                    ceres::ParameterBlockOrdering* ordering, std::set<int>* frames,
                    std::set<int64_t>* features) {
  int added = 0;
  for (const BundleAdjustmentObservation& o : observations) {
    const int64_t feature_id = o.observation.feature_id;
    if (rejected.count({o.frame_id, feature_id}) || !params->HasPose(o.frame_id) ||
        !params->HasFeature(feature_id)) {
      continue;
    }
    Eigen::Matrix3d W;
    if (!SqrtInformation(o.observation.Q, &W)) continue;
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<CorrectedUvdResidual, 3, 4, 3, 3, 3>(
            new CorrectedUvdResidual(camera, T_range_colour, o.observation.z, W, min_depth_m)),
        nullptr, params->q_w_c(o.frame_id), params->t_w_c(o.frame_id), params->p_w(feature_id), k);
    if (frames->insert(o.frame_id).second) {
      problem->SetManifold(params->q_w_c(o.frame_id), manifold);
      ordering->AddElementToGroup(params->q_w_c(o.frame_id), 1);
      ordering->AddElementToGroup(params->t_w_c(o.frame_id), 1);
    }
    if (features->insert(feature_id).second) {
      ordering->AddElementToGroup(params->p_w(feature_id), 0);
    }
    ++added;
  }
  // A group of its own: within a group Ceres orders blocks by address, and k is not in the
  // poses' buffer.
  ordering->AddElementToGroup(k, 2);
  return added;
}

}  // namespace

DepthCorrectionEstimate EstimateDepthCorrection(const BundleAdjustmentProblem& problem,
                                                const BundleAdjustmentResult& solved,
                                                const PinholeCamera& camera,
                                                const Eigen::Isometry3d& T_colour_range,
                                                const BundleAdjustmentOptions& ba) {
  const auto start = std::chrono::steady_clock::now();
  DepthCorrectionEstimate estimate;
  if (problem.T_w_c.empty() || solved.T_w_c.empty()) {
    estimate.failure = "no poses to estimate it from";
    return estimate;
  }
  BundleAdjustmentProblem started;  // the solve's estimate, as the Parameters' layout needs
  started.T_w_c = solved.T_w_c;
  started.p_w = solved.p_w;
  started.anchor_frame_id = problem.anchor_frame_id;
  Parameters params(started);
  std::set<std::pair<int, int64_t>> rejected;
  for (const BundleAdjustmentObservation& o : solved.rejected) {
    rejected.emplace(o.frame_id, o.observation.feature_id);
  }
  double k[3] = {0.0, 0.0, 0.0};
  ceres::EigenQuaternionManifold quaternion_manifold;  // outlives the problem, which uses it
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  const int anchor_id = started.AnchorFrameId();
  std::set<int> frames;
  std::set<int64_t> features;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  estimate.observations = AddObservations(
      problem.observations, rejected, camera, T_colour_range.inverse(), ba.min_depth_m, &params, k,
      &quaternion_manifold, &ceres_problem, ordering.get(), &frames, &features);
  if (estimate.observations == 0 || !frames.count(anchor_id)) {
    estimate.failure = "no observations, or none of the anchor's, to estimate it from";
    return estimate;
  }
  ceres_problem.SetParameterBlockConstant(params.q_w_c(anchor_id));
  ceres_problem.SetParameterBlockConstant(params.t_w_c(anchor_id));

  ceres::Solver::Options options;
  ba_internal::SetLevenbergMarquardt(ba, &options);
  // The reduced system of the poses and the coefficients (which touch every pose): dense for
  // the few hundred poses where a dense factorisation wins (bundle_adjustment.h).
  options.linear_solver_type = static_cast<int>(frames.size()) <= kDenseSchurAlwaysPoses
                                   ? ceres::DENSE_SCHUR
                                   : ceres::SPARSE_SCHUR;
  options.linear_solver_ordering = ordering;
  StopCallback stop(ba.stop);
  options.callbacks.push_back(&stop);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &ceres_problem, &summary);
  estimate.iterations = static_cast<int>(summary.iterations.size());
  estimate.interrupted = stop.fired();
  if (estimate.interrupted || !summary.IsSolutionUsable()) {
    estimate.failure = estimate.interrupted ? "interrupted" : summary.message;
    estimate.seconds = SecondsSince(start);
    return estimate;
  }
  estimate.cost_without = summary.initial_cost;
  estimate.cost_with = summary.final_cost;
  std::copy(k, k + 3, estimate.coefficients.begin());
  estimate.usable = CoefficientCovariance(&ceres_problem, &params, anchor_id, k, frames, features,
                                          ba.num_threads, &estimate.covariance);
  if (!estimate.usable) {
    estimate.failure =
        "the correction's information matrix is singular: the images do not "
        "show the same points at different places";
  }
  estimate.seconds = SecondsSince(start);
  return estimate;
}

RangeImager WithDepthCorrection(const RangeImager& range, const DepthCorrectionEstimate& estimate) {
  RangeImager corrected = range;
  for (int i = 0; i < 3; ++i) corrected.depth_correction[i] += estimate.coefficients[i];
  return corrected;
}

double DepthCorrectionFactorAt(const Eigen::Vector3d& p_r,
                               const std::array<double, 3>& coefficients) {
  return RangeImager::DepthCorrectionFactor(coefficients, p_r.x() / p_r.z(), p_r.y() / p_r.z());
}

double ObservedDepthCorrectionFactor(const FeatureObservation& o, const PinholeCamera& camera,
                                     const Eigen::Isometry3d& T_range_colour,
                                     const std::array<double, 3>& coefficients) {
  const Eigen::Vector3d ray((o.z.x() - camera.cx) / camera.fx, (o.z.y() - camera.cy) / camera.fy,
                            1.0);
  const Eigen::Vector3d p_r = T_range_colour * (o.z.z() * ray.normalized());
  return p_r.z() > 0.0 ? DepthCorrectionFactorAt(p_r, coefficients) : 0.0;
}

BundleAdjustmentProblem WithRangesCorrected(const BundleAdjustmentProblem& problem,
                                            const PinholeCamera& camera,
                                            const Eigen::Isometry3d& T_colour_range,
                                            const std::array<double, 3>& coefficients) {
  BundleAdjustmentProblem corrected = problem;
  const Eigen::Isometry3d T_range_colour = T_colour_range.inverse();
  for (auto* observations : {&corrected.observations, &corrected.registered}) {
    for (BundleAdjustmentObservation& o : *observations) {
      const double factor =
          ObservedDepthCorrectionFactor(o.observation, camera, T_range_colour, coefficients);
      if (!(factor > 0.0)) continue;
      const Eigen::DiagonalMatrix<double, 3> scale(1.0, 1.0, 1.0 / factor);
      o.observation.z.z() /= factor;
      o.observation.Q = scale * o.observation.Q * scale;
    }
  }
  return corrected;
}

std::string DepthCorrectionRefused(const BundleAdjustmentProblem& problem,
                                   const PinholeCamera& camera,
                                   const Eigen::Isometry3d& T_colour_range,
                                   const std::array<double, 3>& coefficients) {
  for (const double k : coefficients) {
    if (!(std::fabs(k) <= RangeImager::kMaxDepthCorrectionCoefficient)) {
      return "a coefficient of " + std::to_string(k) + " is beyond what a calibration allows";
    }
  }
  const Eigen::Isometry3d T_range_colour = T_colour_range.inverse();
  for (const auto* observations : {&problem.observations, &problem.registered}) {
    for (const BundleAdjustmentObservation& o : *observations) {
      const double factor =
          ObservedDepthCorrectionFactor(o.observation, camera, T_range_colour, coefficients);
      if (!(factor >= RangeImager::kMinDepthCorrectionFactor &&
            factor <= RangeImager::kMaxDepthCorrectionFactor)) {
        return "it gives a factor of " + std::to_string(factor) + " at an observation of frame " +
               std::to_string(o.frame_id) + ", beyond what a calibration allows";
      }
    }
  }
  return "";
}

RangeCloud WithRangesCorrected(const RangeCloud& cloud, const std::array<double, 3>& coefficients) {
  const auto& [a, b, c] = coefficients;
  RangeCloud corrected = cloud;
  for (int gy = 0; gy < cloud.grid.height; ++gy) {
    // A rolling shutter's points are read in their row's frame: corrected there.
    const Eigen::Isometry3d to_row = cloud.to_row.empty()
                                         ? Eigen::Isometry3d::Identity()
                                         : Eigen::Isometry3d(cloud.to_row[gy].cast<double>());
    const Eigen::Isometry3d from_row = to_row.inverse();
    for (int gx = 0; gx < cloud.grid.width; ++gx) {
      const size_t cell = static_cast<size_t>(gy) * cloud.grid.width + gx;
      if (!cloud.Valid(static_cast<int>(cell))) continue;
      const Eigen::Vector3d p = to_row * cloud.p_r[cell].cast<double>();
      const Eigen::Vector3d n = to_row.linear() * cloud.n_r[cell].cast<double>();
      const double factor = p.z() > 0.0 ? DepthCorrectionFactorAt(p, coefficients) : 0.0;
      if (!(factor >= RangeImager::kMinDepthCorrectionFactor &&
            factor <= RangeImager::kMaxDepthCorrectionFactor)) {
        const float nan = std::numeric_limits<float>::quiet_NaN();
        corrected.p_r[cell] = corrected.n_r[cell] = Eigen::Vector3f::Constant(nan);
        corrected.sigma_m[cell] = nan;
        continue;
      }
      const double x = p.x() / p.z(), y = p.y() / p.z();
      // The map p -> p / f(p), f of degree 0 in p (so grad f . p = 0), has the Jacobian
      // (I - p g^T / f) / f, g = grad f; a normal goes by its inverse transpose,
      // n + g (p . n) / f up to scale.
      const double f_x = a + 2.0 * c * x, f_y = b + 2.0 * c * y;
      const Eigen::Vector3d g = Eigen::Vector3d(f_x, f_y, -(f_x * x + f_y * y)) / p.z();
      const Eigen::Vector3d n_corrected = (n + g * (p.dot(n) / factor)).normalized();
      corrected.p_r[cell] = (from_row * (p / factor)).cast<float>();
      corrected.n_r[cell] = (from_row.linear() * n_corrected).cast<float>();
      corrected.sigma_m[cell] = static_cast<float>(cloud.sigma_m[cell] / factor);
    }
  }
  return corrected;
}

}  // namespace ieslam
