#include "frontend/registration.h"

#include <functional>
#include <memory>

#include <ceres/rotation.h>
#include <ceres/tiny_solver.h>
#include <ceres/tiny_solver_autodiff_function.h>
#include <glog/logging.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <opengv/point_cloud/PointCloudAdapter.hpp>
#include <opengv/point_cloud/methods.hpp>
#include <opengv/sac/Ransac.hpp>
#include <opengv/sac_problems/point_cloud/PointCloudSacProblem.hpp>

namespace ieslam {
namespace {

using opengv::sac_problems::point_cloud::PointCloudSacProblem;

// OpenGV's problem seeds its generator with the clock, or with a fixed 12345 when built
// with randomSeed = false; this one takes the caller's seed.
class SeededPointCloudProblem : public PointCloudSacProblem {
 public:
  SeededPointCloudProblem(opengv::point_cloud::PointCloudAdapterBase& adapter, uint32_t seed)
      : PointCloudSacProblem(adapter, /*randomSeed=*/false) {
    rng_alg_.seed(seed);
    rng_gen_.reset(new std::function<int()>(std::bind(*rng_dist_, rng_alg_)));
  }
};

std::vector<int> InliersOf(const Eigen::Isometry3d& T_a_b, const std::vector<Eigen::Vector3d>& a,
                           const std::vector<Eigen::Vector3d>& b, double threshold, double* rms) {
  std::vector<int> inliers;
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double e2 = (a[i] - T_a_b * b[i]).squaredNorm();
    if (e2 < threshold * threshold) {
      inliers.push_back(static_cast<int>(i));
      sum += e2;
    }
  }
  *rms = inliers.empty() ? 0.0 : std::sqrt(sum / inliers.size());
  return inliers;
}

// The whitened residuals L_i^-1 (a_i - (Exp(w) R0 b_i + t0 + dt)) of correspondences, as
// functions of a correction x = (w, dt) to a starting pose (R0, t0).
class WhitenedCorrection {
 public:
  explicit WhitenedCorrection(const Eigen::Isometry3d& start) : start_(start) {}

  void Add(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Matrix3d& whitening) {
    a_minus_t0_.push_back(a - start_.translation());
    R0_b_.push_back(start_.linear() * b);
    whitening_.push_back(whitening);
  }

  int NumResiduals() const { return 3 * static_cast<int>(R0_b_.size()); }

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    for (size_t k = 0; k < R0_b_.size(); ++k) {
      const T point[3] = {T(R0_b_[k].x()), T(R0_b_[k].y()), T(R0_b_[k].z())};
      T rotated[3];
      ceres::AngleAxisRotatePoint(x, point, rotated);
      Eigen::Matrix<T, 3, 1> r;
      for (int j = 0; j < 3; ++j) r[j] = T(a_minus_t0_[k][j]) - rotated[j] - x[3 + j];
      Eigen::Map<Eigen::Matrix<T, 3, 1>>(residual + 3 * k) = whitening_[k].cast<T>() * r;
    }
    return true;
  }

  Eigen::Isometry3d Corrected(const Eigen::Matrix<double, 6, 1>& x) const {
    Eigen::Matrix3d dR;
    ceres::AngleAxisToRotationMatrix(x.data(), ceres::ColumnMajorAdapter3x3(dR.data()));
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = dR * start_.linear();
    T.translation() = start_.translation() + x.tail<3>();
    return T;
  }

 private:
  Eigen::Isometry3d start_;
  std::vector<Eigen::Vector3d> a_minus_t0_, R0_b_;
  std::vector<Eigen::Matrix3d> whitening_;
};

// The two points' noise, Sigma_a + R Sigma_b R^T, inverted as the whitening L^-1.
class CorrespondenceNoise {
 public:
  CorrespondenceNoise(const std::vector<Eigen::Matrix3d>& covariances_a,
                      const std::vector<Eigen::Matrix3d>& covariances_b)
      : covariances_a_(covariances_a), covariances_b_(covariances_b) {}

  // L^-1 for correspondence i under rotation R.
  Eigen::Matrix3d Whitening(int i, const Eigen::Matrix3d& R) const {
    const Eigen::Matrix3d S = covariances_a_[i] + R * covariances_b_[i] * R.transpose();
    return Eigen::LLT<Eigen::Matrix3d>(S).matrixL().solve(Eigen::Matrix3d::Identity());
  }

  // The correspondences with r^T S^-1 r <= chi2, and the mean statistic over them.
  std::vector<int> Inliers(const Eigen::Isometry3d& T_a_b, const std::vector<Eigen::Vector3d>& a,
                           const std::vector<Eigen::Vector3d>& b, double chi2,
                           double* mean_chi2) const {
    std::vector<int> inliers;
    double sum = 0.0;
    for (size_t i = 0; i < a.size(); ++i) {
      const double d2 =
          (Whitening(static_cast<int>(i), T_a_b.linear()) * (a[i] - T_a_b * b[i])).squaredNorm();
      if (d2 <= chi2) {
        inliers.push_back(static_cast<int>(i));
        sum += d2;
      }
    }
    *mean_chi2 = inliers.empty() ? 0.0 : sum / inliers.size();
    return inliers;
  }

  // The pose minimising sum r^T S^-1 r over `inliers`, S at the rotation of `start`: Ceres'
  // TinySolver (Levenberg-Marquardt, automatic derivatives) on a correction to `start`, which
  // converges in a few steps from Arun's pose. A ceres::Problem gives the same poses, but
  // its set-up costs more than this 6-parameter fit itself (docs/frontend_notes.md).
  Eigen::Isometry3d WeightedFit(const Eigen::Isometry3d& start,
                                const std::vector<Eigen::Vector3d>& a,
                                const std::vector<Eigen::Vector3d>& b,
                                const std::vector<int>& inliers) const {
    WhitenedCorrection correction(start);
    for (int i : inliers) correction.Add(a[i], b[i], Whitening(i, start.linear()));
    using Function = ceres::TinySolverAutoDiffFunction<WhitenedCorrection, Eigen::Dynamic, 6>;
    const Function function(correction);
    ceres::TinySolver<Function> solver;
    solver.options.max_num_iterations = kMaxIterations;
    Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
    solver.Solve(function, &x);
    if (!x.allFinite()) return start;  // degenerate inliers: the spread check refuses them
    return correction.Corrected(x);
  }

 private:
  static constexpr int kMaxIterations = 10;

  const std::vector<Eigen::Matrix3d>& covariances_a_;
  const std::vector<Eigen::Matrix3d>& covariances_b_;
};

double RmsOf(const Eigen::Isometry3d& T_a_b, const std::vector<Eigen::Vector3d>& a,
             const std::vector<Eigen::Vector3d>& b, const std::vector<int>& selected) {
  double sum = 0.0;
  for (int i : selected) sum += (a[i] - T_a_b * b[i]).squaredNorm();
  return selected.empty() ? 0.0 : std::sqrt(sum / selected.size());
}

// sqrt of the second-largest eigenvalue of the scatter of the selected points.
double Spread(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& selected) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : selected) mean += points[i];
  mean /= selected.size();
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (int i : selected) scatter += (points[i] - mean) * (points[i] - mean).transpose();
  scatter /= selected.size();
  const Eigen::Vector3d eigenvalues =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
  return std::sqrt(std::max(0.0, eigenvalues[1]));  // ascending order
}

// RANSAC and the unweighted refits; then, with `noise`, the weighted ones.
RegistrationResult Register(const std::vector<Eigen::Vector3d>& points_a,
                            const std::vector<Eigen::Vector3d>& points_b,
                            const CorrespondenceNoise* noise, const RegistrationOptions& options) {
  CHECK_EQ(points_a.size(), points_b.size());
  RegistrationResult result;
  const int n = static_cast<int>(points_a.size());
  if (n < std::max(3, options.min_inliers)) {
    result.reason = "too few correspondences: " + std::to_string(n) + " < " +
                    std::to_string(std::max(3, options.min_inliers));
    return result;
  }
  opengv::points_t a(points_a.begin(), points_a.end()), b(points_b.begin(), points_b.end());
  opengv::point_cloud::PointCloudAdapter adapter(a, b);
  auto problem = std::make_shared<SeededPointCloudProblem>(adapter, options.seed);
  opengv::sac::Ransac<PointCloudSacProblem> ransac;
  ransac.sac_model_ = problem;
  ransac.threshold_ = options.inlier_threshold_m;
  ransac.max_iterations_ = options.max_iterations;
  ransac.probability_ = options.probability;
  if (!ransac.computeModel()) {
    result.reason = "RANSAC found no model";
    return result;
  }
  result.ransac_iterations = ransac.iterations_;

  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix().topRows<3>() = ransac.model_coefficients_;
  double rms = 0.0;
  std::vector<int> inliers = InliersOf(T, points_a, points_b, options.inlier_threshold_m, &rms);
  // Least-squares refit (Arun) on the inliers until the set is stable. A refit is kept even
  // when a few inliers drop out past the threshold: it never raises the truncated cost
  // sum_i min(e_i^2, threshold^2) over all correspondences (over the inliers its squared
  // errors sum to no more than the previous model's, and any other correspondence costs at
  // most threshold^2, as before). Keeping RANSAC's model instead would return a pose fitted
  // to three noisy points.
  for (int round = 0; round < options.max_refinements && inliers.size() >= 3; ++round) {
    T.matrix().topRows<3>() = opengv::point_cloud::threept_arun(adapter, inliers);
    std::vector<int> refit_inliers =
        InliersOf(T, points_a, points_b, options.inlier_threshold_m, &rms);
    const bool stable = refit_inliers == inliers;
    inliers = std::move(refit_inliers);
    if (stable) break;
  }
  if (noise != nullptr) {
    // From the unweighted fit: Mahalanobis inliers and the weighted fit to them, until the
    // set is stable (a refit is kept as above).
    inliers = noise->Inliers(T, points_a, points_b, options.inlier_chi2, &result.mean_chi2);
    for (int round = 0; round < options.max_refinements && inliers.size() >= 3; ++round) {
      T = noise->WeightedFit(T, points_a, points_b, inliers);
      std::vector<int> refit_inliers =
          noise->Inliers(T, points_a, points_b, options.inlier_chi2, &result.mean_chi2);
      const bool stable = refit_inliers == inliers;
      inliers = std::move(refit_inliers);
      if (stable) break;
    }
    rms = RmsOf(T, points_a, points_b, inliers);
  }
  result.T_a_b = T;
  result.inliers = inliers;
  result.inlier_ratio = static_cast<double>(inliers.size()) / n;
  result.rms_m = rms;
  if (static_cast<int>(inliers.size()) < options.min_inliers) {
    result.reason = "too few inliers: " + std::to_string(inliers.size()) + " < " +
                    std::to_string(options.min_inliers);
    return result;
  }
  const double spread = Spread(points_a, inliers);
  if (spread < options.min_spread_m) {
    result.reason = "degenerate inliers (collinear or on a tiny patch): spread " +
                    std::to_string(spread) + " m < " + std::to_string(options.min_spread_m) + " m";
    return result;
  }
  result.success = true;
  return result;
}

}  // namespace

const OptionTable<RegistrationOptions>& RegistrationOptions::Table() {
  static const OptionTable<RegistrationOptions>* table = [] {
    using O = RegistrationOptions;
    auto* t = new OptionTable<O>;
    t->Double("inlier_threshold_m", &O::inlier_threshold_m, "RANSAC's inlier distance").Above(0.0);
    t->Int("max_iterations", &O::max_iterations, "RANSAC's iterations at most").Min(1);
    t->Double("probability", &O::probability, "RANSAC's confidence").Above(0.0).Below(1.0);
    t->Int("min_inliers", &O::min_inliers, "inliers a registration needs").Min(3);
    t->Double("min_spread_m", &O::min_spread_m, "how far the inliers must spread").Min(0.0);
    t->Double("inlier_chi2", &O::inlier_chi2, "chi-square 3 dof, 0.999: Mahalanobis inlier gate")
        .Above(0.0);
    t->Bool("use_point_covariances", &O::use_point_covariances,
            "1: gate and weigh by each point's covariance (rig's noise model)");
    t->Uint("seed", &O::seed, "RANSAC's seed: the run's seed").Derived();
    t->Double("inlier_noise_sigmas", &O::inlier_noise_sigmas,
              "inlier distance at least this many range sigmas")
        .Min(0.0);
    t->Int("max_refinements", &O::max_refinements, "least-squares refinements of the inliers")
        .Min(0);
    return t;
  }();
  return *table;
}

RegistrationResult RegisterPointSets(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const RegistrationOptions& options) {
  return Register(points_a, points_b, nullptr, options);
}

RegistrationResult RegisterPointSets(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const std::vector<Eigen::Matrix3d>& covariances_a,
                                     const std::vector<Eigen::Matrix3d>& covariances_b,
                                     const RegistrationOptions& options) {
  CHECK_EQ(covariances_a.size(), points_a.size());
  CHECK_EQ(covariances_b.size(), points_b.size());
  const CorrespondenceNoise noise(covariances_a, covariances_b);
  return Register(points_a, points_b, &noise, options);
}

}  // namespace ieslam
