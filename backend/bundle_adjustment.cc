#include "backend/bundle_adjustment.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <set>
#include <sstream>
#include <utility>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "backend/ba_parameters.h"
#include "backend/ba_residuals.h"
#include "backend/information_filter.h"
#include "backend/pose_covariance.h"
#include "core/error.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

using ba_internal::Parameters;

// The median of the chi-square distribution with 3 degrees of freedom.
constexpr double kChiSquare3Median = 2.365974;
// ... and with 6 (a relative pose).
constexpr double kChiSquare6Median = 5.348121;
// The relative poses are weighed anew (and the problem solved again) when their variance
// factor moves by more than this ratio: finer changes move the estimate far less than its
// uncertainty and would only add solves.
constexpr double kRelativeWeightChange = 1.05;

// The chi-square gate for 6 degrees of freedom with the tail probability that `gate3` has
// for 3 (16.27, 1e-3 -> 22.46), by bisection on the closed-form tails.
double SixDofGate(double gate3) {
  const auto tail3 = [](double x) {
    return std::erfc(std::sqrt(x / 2.0)) + std::sqrt(2.0 * x / M_PI) * std::exp(-x / 2.0);
  };
  const auto tail6 = [](double x) { return std::exp(-x / 2.0) * (1.0 + x / 2.0 + x * x / 8.0); };
  const double p = tail3(gate3);
  double lo = gate3, hi = gate3 + 100.0;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (tail6(mid) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

std::string ObservationName(const BundleAdjustmentObservation& obs) {
  std::ostringstream out;
  out << "bundle adjustment: frame " << obs.frame_id << ", feature " << obs.observation.feature_id;
  return out.str();
}

// `density` is called only where auto needs it.
ceres::LinearSolverType ToCeres(BaLinearSolver solver, int free_poses,
                                const std::function<double()>& density, double* used_density) {
  switch (solver) {
    case BaLinearSolver::kAuto: {
      if (free_poses <= kDenseSchurAlwaysPoses) return ceres::DENSE_SCHUR;
      if (free_poses > kDenseSchurMaxPoses) return ceres::SPARSE_SCHUR;
      *used_density = density();
      return *used_density >= kDenseSchurMinDensity ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
    }
    case BaLinearSolver::kDenseSchur:
      return ceres::DENSE_SCHUR;
    case BaLinearSolver::kSparseSchur:
      return ceres::SPARSE_SCHUR;
    case BaLinearSolver::kSparseNormalCholesky:
      break;
  }
  return ceres::SPARSE_NORMAL_CHOLESKY;
}

// Fills result->pose_covariances{,_euler} of the poses of `frames`. Ceres' tangent of the
// quaternion block is EigenQuaternionManifold's, delta with
// q_true = [cos|delta|, sin|delta| delta/|delta|] * q: a rotation of angle 2|delta| about the
// world axis delta, so phi = 2 delta (tests check this against the manifold itself).
void ComputePoseCovariances(ceres::Problem* ceres_problem, Parameters* params, int anchor_id,
                            const std::set<int>& frames, const std::set<int64_t>& features,
                            const BundleAdjustmentOptions& options,
                            BundleAdjustmentResult* result) {
  std::vector<PoseParameterBlocks> poses;
  for (int frame_id : frames) {
    if (frame_id != anchor_id) {
      poses.push_back({frame_id, params->t_w_c(frame_id), params->q_w_c(frame_id)});
    }
  }
  std::vector<double*> feature_blocks;
  for (int64_t feature_id : features) feature_blocks.push_back(params->p_w(feature_id));
  std::map<int, Matrix6d> tangent;
  if (!PoseTangentCovariances(ceres_problem, poses, feature_blocks, options.covariance_method,
                              options.num_threads, &tangent)) {
    result->covariance_error =
        "the pose covariances could not be computed: the information matrix is singular (a "
        "pose or feature that the observations do not determine)";
    return;
  }
  Matrix6d half_angle_to_phi = Matrix6d::Identity();
  half_angle_to_phi.bottomRightCorner<3, 3>() *= 2.0;
  for (int frame_id : frames) {
    if (frame_id == anchor_id) {
      result->pose_covariances[frame_id].setZero();
      result->pose_covariances_euler[frame_id].setZero();
      continue;
    }
    const Matrix6d P = half_angle_to_phi * tangent.at(frame_id) * half_angle_to_phi;
    result->pose_covariances[frame_id] = P;
    Matrix6d to_euler = Matrix6d::Identity();
    to_euler.bottomRightCorner<3, 3>() =
        EulerZyxFromRotationVectorJacobian(result->poses.at(frame_id).tail<3>());
    result->pose_covariances_euler[frame_id] = to_euler * P * to_euler.transpose();
  }
}

// Each observation's error at the result's poses and points, per component in units of
// sqrt(Q_ii) (BundleAdjustmentResult::ResidualCheck; the redundancy is the caller's).
BundleAdjustmentResult::ResidualCheck CheckResiduals(const BundleAdjustmentProblem& problem,
                                                     const PinholeCamera& camera,
                                                     double min_depth_m,
                                                     const BundleAdjustmentResult& result) {
  std::vector<Eigen::Vector3d> standardized;
  standardized.reserve(problem.observations.size());
  for (const BundleAdjustmentObservation& obs : problem.observations) {
    const FeatureObservation& o = obs.observation;
    const Eigen::Isometry3d& T_w_c = result.T_w_c.at(obs.frame_id);
    const Eigen::Quaterniond q_w_c(T_w_c.linear());
    const Eigen::Vector3d t_w_c = T_w_c.translation();
    const Eigen::Vector3d& p_w = result.p_w.at(o.feature_id);
    Eigen::Vector3d error;
    const UvdResidual residual(camera, o.z, Eigen::Matrix3d::Identity(), min_depth_m);
    if (!residual(q_w_c.coeffs().data(), t_w_c.data(), p_w.data(), error.data())) continue;
    standardized.push_back(error.cwiseQuotient(o.Q.diagonal().cwiseSqrt()));
  }
  BundleAdjustmentResult::ResidualCheck check;
  check.observations = static_cast<int>(standardized.size());
  if (standardized.empty()) return check;
  const double n = static_cast<double>(standardized.size());
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> magnitude;
    magnitude.reserve(standardized.size());
    double sum = 0.0;
    for (const Eigen::Vector3d& e : standardized) {
      magnitude.push_back(std::abs(e[axis]));
      sum += e[axis] * e[axis];
    }
    check.rms[axis] = std::sqrt(sum / n);
    check.robust_sigma[axis] = RobustSigma(std::move(magnitude));
  }
  return check;
}

// One bundle adjustment: the Ceres problem over the parameters, its residual blocks per
// observation (index into problem.observations) and per relative pose, and how many
// residuals use each parameter block, so that a rejected observation's blocks can leave the
// problem with it.
class BundleAdjustmentRun {
 public:
  BundleAdjustmentRun(const BundleAdjustmentProblem& problem, const PinholeCamera& camera,
                      const BundleAdjustmentOptions& options, BundleAdjustmentResult* result)
      : problem_(problem),
        camera_(camera),
        options_(options),
        result_(result),
        params_(problem),
        ceres_problem_(ProblemOptions()) {
    if (options.robust_loss == BaRobustLoss::kHuber) {
      loss_ = std::make_unique<ceres::HuberLoss>(options.huber_scale);
    }
    block_of_.assign(problem.observations.size(), nullptr);
  }

  // The residual blocks, the gauge, and the solver. Throws DataError (AddObservations).
  void Build(int anchor_id) {
    anchor_id_ = anchor_id;
    AddObservations();
    AddRelativePoses();
    if (frame_uses_.count(anchor_id) > 0) {
      ceres_problem_.SetParameterBlockConstant(params_.q_w_c(anchor_id));
      ceres_problem_.SetParameterBlockConstant(params_.t_w_c(anchor_id));
    }
    SetSolverOptions();
  }

  // Solves from the current values; again after each round of rejections.
  void Solve() {
    if (options_.stop && options_.stop()) result_->interrupted = true;
    if (ceres_problem_.NumResidualBlocks() == 0 || result_->interrupted) {
      summary_ = ceres::Solver::Summary();
      return;
    }
    const int free_poses = static_cast<int>(frame_uses_.size() - frame_uses_.count(anchor_id_));
    result_->reduced_system_density = -1.0;
    solver_options_.linear_solver_type = ToCeres(
        options_.linear_solver, free_poses, [this] { return ReducedSystemDensity(); },
        &result_->reduced_system_density);
    if (solver_options_.linear_solver_type != ceres::SPARSE_NORMAL_CHOLESKY) {
      // Features first: eliminating them leaves the reduced camera system of the poses.
      auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
      for (const auto& [feature_id, uses] : feature_uses_) {
        ordering->AddElementToGroup(params_.p_w(feature_id), 0);
      }
      for (const auto& [frame_id, uses] : frame_uses_) {
        ordering->AddElementToGroup(params_.q_w_c(frame_id), 1);
        ordering->AddElementToGroup(params_.t_w_c(frame_id), 1);
      }
      solver_options_.linear_solver_ordering = ordering;
    }
    ceres::Solve(solver_options_, &ceres_problem_, &summary_);
    result_->relative_pose_variance_factor = weight_factor_;
    if (result_->solves++ == 0) result_->initial_cost = summary_.initial_cost;
    result_->linear_solver = ceres::LinearSolverTypeToString(summary_.linear_solver_type_used);
    result_->iterations += static_cast<int>(summary_.iterations.size());
  }

  bool usable() const { return summary_.IsSolutionUsable(); }

  // Weighs the relative poses by their variance factor at the current solution
  // (options.weigh_relative_poses); true when their weight moved by more than
  // kRelativeWeightChange and the problem is to be solved again. RejectOutliers does it too.
  bool Reweigh();

  // Removes the observations and relative poses outside the gate and weighs the relative
  // poses anew (Reweigh); false if neither changed anything.
  bool RejectOutliers();
  // The result's poses, features, costs and diagnostics (solve_time_s from `start`).
  void Collect(int anchor_id, std::chrono::steady_clock::time_point start);

 private:
  static ceres::Problem::Options ProblemOptions() {
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.enable_fast_removal = true;  // rejected observations leave one by one
    return problem_options;
  }

  void AddObservations();
  void AddRelativePoses();
  // The relative poses' weight set to 1 / factor if that moves it by more than
  // kRelativeWeightChange (options.weigh_relative_poses); true if it did.
  bool ReweighTo(double factor);
  void SetSolverOptions();
  // The squared whitened norm of each block still in the problem (infinite where it cannot
  // be evaluated), and the gate: `gate` widened by the kept norms' variance factor, median /
  // chi-square median, robust to the outliers themselves. Where Q understates the noise
  // (real data: calibration, unmodelled distortion) the gate widens; it never narrows (a Q
  // that overstates the noise keeps it).
  double NormsAndGate(const std::vector<ceres::ResidualBlockId>& blocks, double median, double gate,
                      std::vector<double>* norms, double* variance_factor);
  // The share of the pairs of free poses whose block of the reduced camera system is not
  // zero: they share a kept observation's feature or a kept relative pose.
  double ReducedSystemDensity() const;
  // A block no residual uses any more leaves too: Ceres' ordering and covariance would
  // meet a parameter the problem does not determine.
  void ReleaseFrame(int frame_id);

  const BundleAdjustmentProblem& problem_;
  const PinholeCamera& camera_;
  const BundleAdjustmentOptions& options_;
  BundleAdjustmentResult* result_;
  Parameters params_;
  // One loss for every observation, owned here rather than by the problem.
  std::unique_ptr<ceres::LossFunction> loss_;
  // The relative poses' weight, 1 / weight_factor_ (none: 1).
  ceres::LossFunctionWrapper relative_loss_{nullptr, ceres::TAKE_OWNERSHIP};
  double weight_factor_ = 1.0;
  ceres::EigenQuaternionManifold quaternion_manifold_;
  ceres::Problem ceres_problem_;
  std::vector<ceres::ResidualBlockId> block_of_;
  std::vector<ceres::ResidualBlockId> relative_block_;
  std::map<int, int> frame_uses_;
  std::map<int64_t, int> feature_uses_;
  ceres::Solver::Options solver_options_;
  ceres::Solver::Summary summary_;
  int anchor_id_ = -1;

  // Ends the solve once options.stop says so (after the iteration in progress).
  class StopCallback : public ceres::IterationCallback {
   public:
    explicit StopCallback(BundleAdjustmentRun* run) : run_(run) {}
    ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
      if (!run_->options_.stop()) return ceres::SOLVER_CONTINUE;
      run_->result_->interrupted = true;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }

   private:
    BundleAdjustmentRun* run_;
  };
  StopCallback stop_callback_{this};

  // Ends the solve after a successful step that gained less than options.cost_tolerance, or
  // after a Gauss-Newton step whose gain the linear model missed by less than that. Near the
  // optimum the next Gauss-Newton step gains about what the model missed on this one,
  // |1 - rho| times its gain (rho: the actual over the predicted decrease), so it would end
  // the solve at about the same point. That holds for undamped steps only: a damped step is
  // short and nearly linear (rho ~ 1) however far it stops from the optimum. So the second
  // test applies only while the solve started nearly as Gauss-Newton (a trust region of at
  // least kGaussNewtonRadius) and no step has failed, which would have shrunk the region.
  class CostToleranceCallback : public ceres::IterationCallback {
   public:
    CostToleranceCallback(double tolerance, double initial_radius)
        : tolerance_(tolerance), gauss_newton_start_(initial_radius >= kGaussNewtonRadius) {}
    ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
      if (summary.iteration == 0) {  // a new solve
        damped_ = !gauss_newton_start_;
        return ceres::SOLVER_CONTINUE;
      }
      if (!summary.step_is_successful) {
        damped_ = true;
        return ceres::SOLVER_CONTINUE;
      }
      const double missed = std::abs(1.0 - summary.relative_decrease) * summary.cost_change;
      return summary.cost_change < tolerance_ || (!damped_ && missed < tolerance_)
                 ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                 : ceres::SOLVER_CONTINUE;
    }

   private:
    // Levenberg-Marquardt's damping is the reciprocal of the radius relative to the
    // Jacobi-scaled diagonal: at 1e6 a step is Gauss-Newton's but in directions a million
    // times weaker than the diagonal.
    static constexpr double kGaussNewtonRadius = 1e6;
    double tolerance_;
    bool gauss_newton_start_;
    bool damped_ = false;
  };
  CostToleranceCallback cost_tolerance_callback_{options_.cost_tolerance,
                                                 options_.initial_trust_region_radius};
};

void BundleAdjustmentRun::AddObservations() {
  for (size_t k = 0; k < problem_.observations.size(); ++k) {
    const BundleAdjustmentObservation& obs = problem_.observations[k];
    const FeatureObservation& o = obs.observation;
    if (!params_.HasPose(obs.frame_id)) throw DataError(ObservationName(obs) + ": unknown frame");
    if (!params_.HasFeature(o.feature_id)) {
      throw DataError(ObservationName(obs) + ": unknown feature");
    }
    Eigen::Matrix3d W;
    if (!o.z.allFinite() || !SqrtInformation(o.Q, &W)) {
      throw DataError(ObservationName(obs) +
                      ": z is not finite or Q is not symmetric positive definite");
    }
    const Eigen::Vector3d p_c =
        problem_.T_w_c.at(obs.frame_id).inverse() * problem_.p_w.at(o.feature_id);
    if (!(p_c.z() > options_.min_depth_m)) {
      throw DataError(ObservationName(obs) + ": the point is behind the camera (z = " +
                      std::to_string(p_c.z()) + " m) at the initial estimate");
    }
    double* q = params_.q_w_c(obs.frame_id);
    block_of_[k] = ceres_problem_.AddResidualBlock(
        UvdResidual::Create(camera_, o.z, W, options_.min_depth_m), loss_.get(), q,
        params_.t_w_c(obs.frame_id), params_.p_w(o.feature_id));
    if (frame_uses_[obs.frame_id]++ == 0) ceres_problem_.SetManifold(q, &quaternion_manifold_);
    ++feature_uses_[o.feature_id];
  }
}

void BundleAdjustmentRun::AddRelativePoses() {
  for (const RelativePoseConstraint& c : problem_.relative_poses) {
    const std::string name = "bundle adjustment: relative pose of frames " +
                             std::to_string(c.frame_i) + " and " + std::to_string(c.frame_j);
    if (!params_.HasPose(c.frame_i) || !params_.HasPose(c.frame_j) || c.frame_i == c.frame_j) {
      throw DataError(name + ": unknown or repeated frame");
    }
    if (!c.sqrt_information.allFinite() || !c.T_sj_si.matrix().allFinite() ||
        !c.T_c_s.matrix().allFinite()) {
      throw DataError(name + ": not finite");
    }
    relative_block_.push_back(ceres_problem_.AddResidualBlock(
        RelativePoseResidual::Create(c.T_sj_si, c.T_c_s, c.sqrt_information), &relative_loss_,
        params_.q_w_c(c.frame_i), params_.t_w_c(c.frame_i), params_.q_w_c(c.frame_j),
        params_.t_w_c(c.frame_j)));
    for (const int frame_id : {c.frame_i, c.frame_j}) {
      if (frame_uses_[frame_id]++ == 0) {
        ceres_problem_.SetManifold(params_.q_w_c(frame_id), &quaternion_manifold_);
      }
    }
  }
}

void BundleAdjustmentRun::SetSolverOptions() {
  ba_internal::SetLevenbergMarquardt(options_, &solver_options_);
  if (options_.stop) solver_options_.callbacks.push_back(&stop_callback_);
  if (options_.cost_tolerance > 0.0) {
    solver_options_.callbacks.push_back(&cost_tolerance_callback_);
  }
}

double BundleAdjustmentRun::NormsAndGate(const std::vector<ceres::ResidualBlockId>& blocks,
                                         double median, double gate, std::vector<double>* norms,
                                         double* variance_factor) {
  norms->assign(blocks.size(), 0.0);
  std::vector<double> kept;
  for (size_t k = 0; k < blocks.size(); ++k) {
    if (blocks[k] == nullptr) continue;
    double half_squared_norm = 0.0;
    const bool evaluated = ceres_problem_.EvaluateResidualBlock(
        blocks[k], /*apply_loss_function=*/false, &half_squared_norm, nullptr, nullptr);
    (*norms)[k] = evaluated ? 2.0 * half_squared_norm : std::numeric_limits<double>::infinity();
    kept.push_back((*norms)[k]);
  }
  if (kept.empty()) return std::numeric_limits<double>::infinity();
  const auto middle = kept.begin() + kept.size() / 2;
  std::nth_element(kept.begin(), middle, kept.end());
  *variance_factor = std::max(1.0, *middle / median);
  return gate * *variance_factor;
}

double BundleAdjustmentRun::ReducedSystemDensity() const {
  // Free poses numbered 0..n-1. Each observation's pose is looked up once, not each pair's: a
  // feature seen by k poses fills k(k-1)/2 blocks, millions per solve where a few hundred poses
  // look at one room.
  std::map<int, int> index;
  for (const auto& [frame_id, uses] : frame_uses_) {
    if (frame_id != anchor_id_) index.emplace(frame_id, static_cast<int>(index.size()));
  }
  const int n = static_cast<int>(index.size());
  if (n < 2) return 1.0;
  const auto index_of = [&index](int frame_id) {
    const auto it = index.find(frame_id);
    return it == index.end() ? -1 : it->second;
  };
  std::vector<char> filled(static_cast<size_t>(n) * n, 0);
  const auto fill = [&](int ia, int ib) {
    if (ia < 0 || ib < 0 || ia == ib) return;
    filled[static_cast<size_t>(std::min(ia, ib)) * n + std::max(ia, ib)] = 1;
  };
  std::vector<std::pair<int64_t, int>> seen;  // (feature, pose index) of each kept observation
  for (size_t k = 0; k < block_of_.size(); ++k) {
    if (block_of_[k] == nullptr) continue;
    seen.emplace_back(problem_.observations[k].observation.feature_id,
                      index_of(problem_.observations[k].frame_id));
  }
  std::sort(seen.begin(), seen.end());
  for (size_t first = 0; first < seen.size();) {
    size_t last = first;
    while (last < seen.size() && seen[last].first == seen[first].first) ++last;
    for (size_t i = first; i < last; ++i) {
      for (size_t j = i + 1; j < last; ++j) fill(seen[i].second, seen[j].second);
    }
    first = last;
  }
  for (size_t k = 0; k < relative_block_.size(); ++k) {
    if (relative_block_[k] != nullptr) {
      fill(index_of(problem_.relative_poses[k].frame_i),
           index_of(problem_.relative_poses[k].frame_j));
    }
  }
  const size_t blocks = std::count(filled.begin(), filled.end(), 1);
  return static_cast<double>(blocks) / (static_cast<double>(n) * (n - 1) / 2);
}

void BundleAdjustmentRun::ReleaseFrame(int frame_id) {
  if (--frame_uses_[frame_id] == 0) {
    frame_uses_.erase(frame_id);
    ceres_problem_.RemoveParameterBlock(params_.q_w_c(frame_id));
    ceres_problem_.RemoveParameterBlock(params_.t_w_c(frame_id));
  }
}

bool BundleAdjustmentRun::Reweigh() {
  if (!options_.weigh_relative_poses) return false;
  std::vector<double> norms;
  double factor = 1.0;
  NormsAndGate(relative_block_, kChiSquare6Median, 1.0, &norms, &factor);
  return ReweighTo(factor);
}

bool BundleAdjustmentRun::ReweighTo(double factor) {
  if (!options_.weigh_relative_poses) return false;
  if (std::abs(std::log(factor / weight_factor_)) <= std::log(kRelativeWeightChange)) return false;
  weight_factor_ = factor;
  relative_loss_.Reset(new ceres::ScaledLoss(nullptr, 1.0 / factor, ceres::TAKE_OWNERSHIP),
                       ceres::TAKE_OWNERSHIP);
  return true;
}

bool BundleAdjustmentRun::RejectOutliers() {
  std::vector<double> squared_norm, relative_norm;
  const double gate = NormsAndGate(block_of_, kChiSquare3Median, options_.rejection_chi2,
                                   &squared_norm, &result_->rejection_variance_factor);
  // Relative poses on the same scale: a wrong alignment disagrees with the others.
  double relative_factor = 1.0;
  const double relative_gate =
      NormsAndGate(relative_block_, kChiSquare6Median, SixDofGate(options_.rejection_chi2),
                   &relative_norm, &relative_factor);
  // The norms are the unweighted ones, so the factor is measured afresh each time, not on
  // top of the last; the solve that follows the rejections uses it.
  bool rejected = ReweighTo(relative_factor);
  for (size_t k = 0; k < block_of_.size(); ++k) {
    if (block_of_[k] == nullptr || !(squared_norm[k] > gate)) continue;
    const BundleAdjustmentObservation& obs = problem_.observations[k];
    ceres_problem_.RemoveResidualBlock(block_of_[k]);
    block_of_[k] = nullptr;
    rejected = true;
    ReleaseFrame(obs.frame_id);
    if (--feature_uses_[obs.observation.feature_id] == 0) {
      feature_uses_.erase(obs.observation.feature_id);
      ceres_problem_.RemoveParameterBlock(params_.p_w(obs.observation.feature_id));
    }
  }
  for (size_t k = 0; k < relative_block_.size(); ++k) {
    if (relative_block_[k] == nullptr || !(relative_norm[k] > relative_gate)) continue;
    ceres_problem_.RemoveResidualBlock(relative_block_[k]);
    relative_block_[k] = nullptr;
    rejected = true;
    ++result_->rejected_relative_poses;
    ReleaseFrame(problem_.relative_poses[k].frame_i);
    ReleaseFrame(problem_.relative_poses[k].frame_j);
  }
  return rejected;
}

void BundleAdjustmentRun::Collect(int anchor_id, std::chrono::steady_clock::time_point start) {
  BundleAdjustmentResult& result = *result_;
  result.observations = static_cast<int>(problem_.observations.size());
  for (size_t k = 0; k < block_of_.size(); ++k) {
    if (block_of_[k] == nullptr) result.rejected.push_back(problem_.observations[k]);
  }
  result.relative_pose_kept.assign(relative_block_.size(), 0);
  for (size_t k = 0; k < relative_block_.size(); ++k) {
    result.relative_pose_kept[k] = relative_block_[k] != nullptr;
  }
  result.final_cost = summary_.final_cost;
  result.num_residuals = ceres_problem_.NumResiduals();
  result.usable = ceres_problem_.NumResidualBlocks() == 0 || summary_.IsSolutionUsable();
  result.termination = std::string(ceres::TerminationTypeToString(summary_.termination_type)) +
                       ": " + summary_.message;
  for (const auto& [frame_id, offset] : params_.pose_offsets()) {
    result.T_w_c[frame_id] = params_.Pose(frame_id);
    result.poses[frame_id] = IsometryToPose(result.T_w_c[frame_id]);
  }
  // The anchor comes back as given, not through a quaternion round trip.
  result.T_w_c[anchor_id] = problem_.T_w_c.at(anchor_id);
  result.poses[anchor_id] = IsometryToPose(problem_.T_w_c.at(anchor_id));
  for (const auto& [feature_id, offset] : params_.feature_offsets()) {
    result.p_w[feature_id] = params_.Feature(feature_id);
  }
  result.solve_time_s = SecondsSince(start);
  // A diagnostic after the solve, not part of its time.
  result.residual_check = CheckResiduals(problem_, camera_, options_.min_depth_m, result);
  const int free_parameters =
      6 * static_cast<int>(frame_uses_.size() - frame_uses_.count(anchor_id)) +
      3 * static_cast<int>(feature_uses_.size());
  if (result.num_residuals > 0) {
    result.residual_check.redundancy =
        static_cast<double>(result.num_residuals - free_parameters) / result.num_residuals;
  }
  std::set<int> observed_frames;
  for (const auto& [frame_id, uses] : frame_uses_) observed_frames.insert(frame_id);
  std::set<int64_t> observed_features;
  for (const auto& [feature_id, uses] : feature_uses_) observed_features.insert(feature_id);
  if (options_.compute_covariances && result.usable && !result.interrupted &&
      !observed_frames.empty() &&
      (!options_.covariances_wanted || options_.covariances_wanted(result))) {
    const auto covariance_start = std::chrono::steady_clock::now();
    ComputePoseCovariances(&ceres_problem_, &params_, anchor_id, observed_frames, observed_features,
                           options_, &result);
    result.covariance_time_s = SecondsSince(covariance_start);
  }
}

}  // namespace

double RobustSigma(std::vector<double> magnitudes) {
  if (magnitudes.empty()) return 0.0;
  const auto middle = magnitudes.begin() + magnitudes.size() / 2;
  std::nth_element(magnitudes.begin(), middle, magnitudes.end());
  return 1.4826 * *middle;
}

int BundleAdjustmentProblem::AnchorFrameId() const {
  CHECK(!T_w_c.empty()) << "bundle adjustment problem without poses";
  return anchor_frame_id >= 0 ? anchor_frame_id : T_w_c.begin()->first;
}

BundleAdjustmentProblem MakeProblemFromFilter(
    const InformationFilter& filter,
    const std::map<int, std::vector<FeatureObservation>>& observations_by_frame,
    const std::map<int, std::vector<FeatureObservation>>& registered_by_frame) {
  BundleAdjustmentProblem problem;
  for (int frame_id : filter.frame_ids()) {
    problem.T_w_c[frame_id] = PoseToIsometry(filter.pose(frame_id));
  }
  for (int64_t feature_id : filter.feature_ids()) {
    problem.p_w[feature_id] = filter.feature(feature_id);
  }
  if (!filter.frame_ids().empty()) problem.anchor_frame_id = filter.frame_ids().front();
  const auto add = [&filter](int frame_id, const std::vector<FeatureObservation>& observations,
                             std::vector<BundleAdjustmentObservation>* into) {
    for (const FeatureObservation& obs : observations) {
      if (!filter.HasFeature(obs.feature_id)) {
        // A pending feature (seen from too few poses to enter the filter: one, by default)
        // constrains no pose; the filter did not use its sighting, nor does the problem.
        if (filter.IsPending(obs.feature_id)) continue;
        throw DataError(ObservationName({frame_id, obs}) +
                        ": the filter does not hold the feature");
      }
      into->push_back({frame_id, obs});
    }
  };
  for (const auto& [frame_id, observations] : observations_by_frame) {
    if (!filter.HasPose(frame_id)) continue;
    add(frame_id, observations, &problem.observations);
    if (registered_by_frame.empty()) continue;
    const auto registered = registered_by_frame.find(frame_id);
    add(frame_id, registered != registered_by_frame.end() ? registered->second : observations,
        &problem.registered);
  }
  return problem;
}

BundleAdjustmentProblem WithPoses(const BundleAdjustmentProblem& problem,
                                  const std::map<int, Eigen::Isometry3d>& T_w_c,
                                  const PinholeCamera& camera) {
  BundleAdjustmentProblem started = problem;
  for (auto& [frame_id, T] : started.T_w_c) {
    const auto it = T_w_c.find(frame_id);
    if (it == T_w_c.end()) {
      throw DataError("frame " + std::to_string(frame_id) + ": no pose to start the problem from");
    }
    T = it->second;
  }
  std::map<int64_t, std::array<std::vector<double>, 3>> placed;
  for (const BundleAdjustmentObservation& obs : problem.observations) {
    const Eigen::Vector3d p_w = ObservationToWorld(IsometryToPose(started.T_w_c.at(obs.frame_id)),
                                                   obs.observation.z, camera);
    for (int axis = 0; axis < 3; ++axis)
      placed[obs.observation.feature_id][axis].push_back(p_w[axis]);
  }
  for (auto& [feature_id, coordinates] : placed) {
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double>& values = coordinates[axis];
      std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
      started.p_w.at(feature_id)[axis] = values[values.size() / 2];
    }
  }
  return started;
}

BundleAdjustmentResult SolveBundleAdjustment(const BundleAdjustmentProblem& problem,
                                             const PinholeCamera& camera,
                                             const BundleAdjustmentOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  CHECK(camera.fx > 0.0 && camera.fy > 0.0) << "bundle adjustment needs a calibrated camera";
  const auto start = std::chrono::steady_clock::now();
  BundleAdjustmentResult result;
  if (problem.T_w_c.empty()) {
    result.usable = true;
    result.termination = "empty problem";
    return result;
  }
  const int anchor_id = problem.AnchorFrameId();
  if (problem.T_w_c.count(anchor_id) == 0) {
    throw DataError("bundle adjustment: the anchor frame " + std::to_string(anchor_id) +
                    " is not among the poses");
  }
  BundleAdjustmentRun run(problem, camera, options, &result);
  run.Build(anchor_id);
  run.Solve();
  // Rounds of rejections and of the relative poses' weighing, measured on what the last
  // solve kept (only the weighing when rejection_chi2 is 0).
  const bool rejecting = options.rejection_chi2 > 0.0;
  for (int round = 0; round < options.max_rejection_rounds && run.usable() && !result.interrupted;
       ++round) {
    if (!(rejecting ? run.RejectOutliers() : run.Reweigh())) break;
    run.Solve();
  }
  run.Collect(anchor_id, start);
  return result;
}

Eigen::Matrix3d EulerZyxFromRotationVectorJacobian(const Eigen::Vector3d& alpha_beta_gamma) {
  const double a = alpha_beta_gamma[0];
  const double b = alpha_beta_gamma[1];
  if (std::abs(std::cos(b)) < kGimbalLockCosBeta) {
    return Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  // omega = E (alpha', beta', gamma')^T for R = Rz(a) Ry(b) Rx(g): the rate of each angle
  // turns about its own axis as seen in the world, ez, Rz ey and Rz Ry ex.
  Eigen::Matrix3d E;
  E.col(0) << 0.0, 0.0, 1.0;
  E.col(1) << -std::sin(a), std::cos(a), 0.0;
  E.col(2) << std::cos(a) * std::cos(b), std::sin(a) * std::cos(b), -std::sin(b);
  return E.inverse();
}

}  // namespace ieslam
