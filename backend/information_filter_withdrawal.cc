// InformationFilter::WithdrawInconsistent: observations the final estimate contradicts taken
// back out of the information form.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include <glog/logging.h>

#include "backend/information_filter.h"
#include "core/error.h"
#include "core/stopwatch.h"

namespace ieslam {

namespace {

// Conjugate-gradient iterations a round's solve may take before the factor anew takes over.
constexpr int kMaxIterations = 200;

// The squared whitened residual of an observation at the estimate; infinity where the feature
// lies on or behind the camera plane (no prediction there agrees with any observation).
double SquaredResidual(const FeatureObservation& obs, const Vector6d& T_w_c,
                       const Eigen::Vector3d& p_w, const PinholeCamera& camera, double min_depth) {
  if (!(WorldToCamera(T_w_c, p_w).z() > min_depth)) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d e = obs.z - PredictObservation(T_w_c, p_w, camera);
  return e.dot(obs.Q.ldlt().solve(e));
}

// Conjugate gradients on A x = b (A's upper triangle given) from *x, preconditioned by an exact
// factor of a nearby matrix. Stops once the preconditioned residual's norm, the error's
// Mahalanobis norm were the factor's matrix A, is below `tolerance`; false if it is not
// within max_iterations.
bool SolveNear(const Eigen::Map<const Eigen::SparseMatrix<double>>& upper,
               const InformationFactor& near, const Eigen::VectorXd& b, double tolerance,
               int max_iterations, Eigen::VectorXd* x, int* iterations) {
  const auto A = upper.selfadjointView<Eigen::Upper>();
  Eigen::VectorXd r = b - A * *x;
  Eigen::VectorXd z = near.Solve(r);
  Eigen::VectorXd p = z;
  double rz = r.dot(z);
  for (*iterations = 0; *iterations < max_iterations; ++*iterations) {
    if (!(rz >= 0.0)) return false;
    if (std::sqrt(rz) < tolerance) return true;
    const Eigen::VectorXd Ap = A * p;
    const double alpha = rz / p.dot(Ap);
    *x += alpha * p;
    r -= alpha * Ap;
    z = near.Solve(r);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return rz >= 0.0 && std::sqrt(rz) < tolerance;
}

}  // namespace

void InformationFilter::AddTakenInformation(const TakenObservation& taken, double sign) {
  ObservationJacobians jacobians;
  // It was linearised there when taken in, so it can be again.
  CHECK(LinearizeAt(taken.T_w_c, taken.p_w, &jacobians));
  const FeatureObservation& obs = taken.observation;
  const Eigen::Matrix3d W = obs.Q.inverse();
  const Eigen::Matrix<double, 6, 3> JpT_W = jacobians.J_p.transpose() * W;
  const Eigen::Matrix3d JfT_W = jacobians.J_f.transpose() * W;
  // The same z - h(X) + H X as the update's (eq. 9), at the same point.
  const Eigen::Vector3d z_lin =
      obs.z - jacobians.h + jacobians.J_p * taken.T_w_c + jacobians.J_f * taken.p_w;
  const int pose = pose_offset_.at(taken.frame_id);
  const int feature = feature_offset_.at(obs.feature_id);
  const Eigen::Matrix<double, 6, 3> I_pf = JpT_W * jacobians.J_f;
  matrix_.AddToDiagonalBlock(pose, sign * (JpT_W * jacobians.J_p));
  matrix_.AddToDiagonalBlock(feature, sign * (JfT_W * jacobians.J_f));
  // The coupling lives in the later variable's columns.
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (pose < feature) {
        matrix_.AddToEntry(pose + r, feature + c, sign * I_pf(r, c));
      } else {
        matrix_.AddToEntry(feature + c, pose + r, sign * I_pf(r, c));
      }
    }
  }
  info_vector_.segment<6>(pose) += sign * (JpT_W * z_lin);
  info_vector_.segment<3>(feature) += sign * (JfT_W * z_lin);
}

std::vector<int> InformationFilter::WithdrawalRound(int anchor,
                                                    std::unordered_map<int64_t, int>* feature_left,
                                                    std::unordered_map<int, int>* pose_left,
                                                    WithdrawalStatistics* stats) {
  std::vector<std::pair<double, int>> failing;  // (squared residual, index in taken_)
  int tested = 0;
  for (int k = 0; k < static_cast<int>(taken_.size()); ++k) {
    const TakenObservation& t = taken_[k];
    if (t.withdrawn) continue;
    ++tested;
    const double r2 =
        SquaredResidual(t.observation, pose(t.frame_id), FeatureEstimate(t.observation.feature_id),
                        camera_, options_.min_depth_m);
    if (r2 > options_.gate_chi2) failing.emplace_back(r2, k);
  }
  if (stats->rounds == 0) stats->tested = tested;
  // Worst first; ties in the order taken, for the same result on every run.
  std::sort(failing.begin(), failing.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  // One observation of a feature a round: a wrong one pulls its feature, and with it the
  // feature's other observations past the gate until it is gone.
  std::vector<int> withdrawn;
  std::unordered_set<int64_t> features_done;
  stats->kept_failing = 0;
  for (const auto& [r2, k] : failing) {
    TakenObservation& t = taken_[k];
    if (!features_done.insert(t.observation.feature_id).second) continue;
    int& on_feature = (*feature_left)[t.observation.feature_id];
    int& on_pose = (*pose_left)[t.frame_id];
    if (on_feature <= 1 || (t.frame_id != anchor && on_pose <= options_.min_known_features)) {
      ++stats->kept_failing;
      continue;
    }
    --on_feature;
    --on_pose;
    t.withdrawn = true;
    withdrawn.push_back(k);
  }
  return withdrawn;
}

WithdrawalStatistics InformationFilter::WithdrawInconsistent() {
  const auto start = std::chrono::steady_clock::now();
  CheckRecovered();
  WithdrawalStatistics stats;
  const double gate = options_.gate_chi2;
  if (gate <= 0.0 || options_.max_withdrawal_rounds <= 0 || taken_.empty()) return stats;
  // What stays in I of each feature and pose (the observations of a restored snapshot are not
  // in taken_, so a pose or feature they hold is counted short: only ever the safer way).
  std::unordered_map<int64_t, int> feature_left;
  std::unordered_map<int, int> pose_left;
  for (const TakenObservation& t : taken_) {
    if (t.withdrawn) continue;
    ++feature_left[t.observation.feature_id];
    ++pose_left[t.frame_id];
  }
  const int anchor = frame_ids_.front();
  // The rounds' states are solved by conjugate gradients preconditioned with the factor of
  // the matrix before them (a few hundred rank-3 changes at most); the factor anew from the
  // matrix at the end makes them exact, and the filter's queries with them.
  const Eigen::VectorXd state_before = state_;
  Factor().MakeExact();
  std::unique_ptr<InformationFactor> before = std::move(factor_);
  std::vector<int> all_withdrawn;
  for (int round = 0; round < options_.max_withdrawal_rounds; ++round) {
    std::vector<int> withdrawn = WithdrawalRound(anchor, &feature_left, &pose_left, &stats);
    if (withdrawn.empty()) break;
    for (int k : withdrawn) AddTakenInformation(taken_[k], -1.0);
    all_withdrawn.insert(all_withdrawn.end(), withdrawn.begin(), withdrawn.end());
    stats.withdrawn += static_cast<int>(withdrawn.size());
    ++stats.rounds;
    Eigen::VectorXd x = state_;
    int iterations = 0;
    const bool solved = SolveNear(matrix_.Upper(), *before, info_vector_, options_.cg_tolerance,
                                  kMaxIterations, &x, &iterations);
    stats.cg_iterations += iterations;
    if (!solved) break;  // the factor anew below recovers the state exactly
    state_ = std::move(x);
  }
  if (all_withdrawn.empty()) {
    factor_ = std::move(before);
  } else {
    // The dense factor keeps sums of the blocks it was given: a factor anew from the matrix.
    try {
      InformationFactor& factor = Factor();
      factor.MakeExact();
      state_ = factor.Solve(info_vector_);
    } catch (const DataError&) {
      // Not expected with a feature's last observation and a pose's last few kept; should it
      // happen, they all go back in and the filter is as it was.
      for (int k : all_withdrawn) {
        AddTakenInformation(taken_[k], 1.0);
        taken_[k].withdrawn = false;
      }
      factor_ = std::move(before);
      state_ = state_before;
      stats.put_back = stats.withdrawn;
      stats.withdrawn = 0;
    }
  }
  stats.seconds = SecondsSince(start);
  return stats;
}

}  // namespace ieslam
