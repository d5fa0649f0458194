// InformationFilter::WithdrawInconsistent: observations the final estimate contradicts taken
// back out of the information form.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
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
    const double curvature = p.dot(Ap);
    if (!(curvature > 0.0)) return false;  // not positive definite along p
    const double alpha = rz / curvature;
    *x += alpha * p;
    r -= alpha * Ap;
    z = near.Solve(r);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return rz >= 0.0 && std::sqrt(rz) < tolerance;
}

// What stays in I of each feature and pose as the rounds withdraw. A feature keeps one
// observation; a pose other than the anchor keeps min_ties ties (observations of features
// that another observation holds too), as a pose needs to enter the filter, and every pose
// stays tied to the anchor through them. What a snapshot restored is not in `taken`: its
// poses are taken as tied to the anchor, and each of its features as seen from them once
// more (its observations there are in I for good).
class KeptObservations {
 public:
  KeptObservations(const std::vector<TakenObservation>& taken, const std::vector<int>& restored,
                   const std::unordered_set<int64_t>& restored_features, int anchor, int min_ties)
      : taken_(taken),
        restored_(restored),
        restored_features_(restored_features),
        anchor_(anchor),
        min_ties_(min_ties) {
    for (int k = 0; k < static_cast<int>(taken.size()); ++k) {
      if (!taken[k].withdrawn) by_feature_[taken[k].observation.feature_id].push_back(k);
    }
    for (const auto& [feature, kept] : by_feature_) {
      if (Seen(feature) < 2) continue;
      for (int k : kept) ++ties_[taken[k].frame_id];
    }
  }

  // Counts taken[k] off if what stays keeps the rules (but for the anchor's connection, which
  // Connected() checks once a round); false, with nothing changed, if not.
  bool Withdraw(int k) {
    const int64_t feature = taken_[k].observation.feature_id;
    std::vector<int>& kept = by_feature_[feature];
    if (kept.size() < 2) return false;
    const int frame = taken_[k].frame_id;
    // Seen twice, the other observation's pose loses its tie too.
    const int other = Seen(feature) == 2 ? taken_[kept[0] == k ? kept[1] : kept[0]].frame_id : -1;
    if (!KeepsTies(frame) || (other >= 0 && !KeepsTies(other))) return false;
    kept.erase(std::find(kept.begin(), kept.end(), k));
    --ties_[frame];
    if (other >= 0) --ties_[other];
    return true;
  }

  void PutBack(int k) {
    const int64_t feature = taken_[k].observation.feature_id;
    std::vector<int>& kept = by_feature_[feature];
    kept.insert(std::lower_bound(kept.begin(), kept.end(), k), k);
    if (Seen(feature) == 2) {
      for (int j : kept) ++ties_[taken_[j].frame_id];
    } else {
      ++ties_[taken_[k].frame_id];
    }
  }

  // Whether every pose of a kept observation is tied to the anchor through kept observations.
  bool Connected() const {
    std::unordered_map<int, int> parent;
    const std::function<int(int)> root = [&](int frame) {
      auto it = parent.try_emplace(frame, frame).first;
      if (it->second == frame) return frame;
      const int r = root(it->second);
      parent[frame] = r;
      return r;
    };
    const auto join = [&](int a, int b) { parent[root(a)] = root(b); };
    for (int frame : restored_) join(frame, anchor_);
    for (const auto& [feature, kept] : by_feature_) {
      const int first = restored_features_.count(feature) > 0 ? anchor_ : taken_[kept[0]].frame_id;
      for (int k : kept) join(taken_[k].frame_id, first);
    }
    const int anchor_root = root(anchor_);
    for (const auto& [feature, kept] : by_feature_) {
      for (int k : kept) {
        if (root(taken_[k].frame_id) != anchor_root) return false;
      }
    }
    return true;
  }

 private:
  // The observations of `feature` in I: the kept ones, and one for a restored feature's.
  int Seen(int64_t feature) const {
    const auto it = by_feature_.find(feature);
    const int kept = it == by_feature_.end() ? 0 : static_cast<int>(it->second.size());
    return kept + (restored_features_.count(feature) > 0 ? 1 : 0);
  }
  bool KeepsTies(int frame) const {
    if (frame == anchor_) return true;
    const auto it = ties_.find(frame);
    return it != ties_.end() && it->second > min_ties_;
  }

  const std::vector<TakenObservation>& taken_;
  const std::vector<int>& restored_;
  const std::unordered_set<int64_t>& restored_features_;
  const int anchor_;
  const int min_ties_;
  std::unordered_map<int64_t, std::vector<int>> by_feature_;  // kept, ascending
  std::unordered_map<int, int> ties_;                         // by frame
};

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

std::vector<std::pair<double, int>> InformationFilter::FailingObservations() const {
  std::vector<std::pair<double, int>> failing;
  for (int k = 0; k < static_cast<int>(taken_.size()); ++k) {
    const TakenObservation& t = taken_[k];
    if (t.withdrawn) continue;
    const double r2 =
        SquaredResidual(t.observation, state_.segment<6>(pose_offset_.at(t.frame_id)),
                        FeatureEstimate(t.observation.feature_id), camera_, options_.min_depth_m);
    if (r2 > options_.gate_chi2) failing.emplace_back(r2, k);
  }
  // Worst first; ties in the order taken, for the same result on every run.
  std::sort(failing.begin(), failing.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  return failing;
}

WithdrawalStatistics InformationFilter::WithdrawInconsistent() {
  const auto start = std::chrono::steady_clock::now();
  CheckRecovered();
  WithdrawalStatistics stats;
  if (options_.gate_chi2 <= 0.0 || options_.max_withdrawal_rounds <= 0 || taken_.empty()) {
    return stats;
  }
  for (const TakenObservation& t : taken_) stats.tested += t.withdrawn ? 0 : 1;
  const std::vector<int> restored(frame_ids_.begin(), frame_ids_.begin() + restored_poses_);
  const std::unordered_set<int64_t> restored_features(feature_ids_.begin(),
                                                      feature_ids_.begin() + restored_features_);
  KeptObservations kept(taken_, restored, restored_features, frame_ids_.front(),
                        options_.min_known_features);
  // The rounds' states are solved by conjugate gradients preconditioned with the factor of
  // the matrix before them (a few hundred rank-3 changes at most); a factor anew from the
  // matrix at the end makes them exact, and the filter's queries with them.
  const Eigen::VectorXd state_before = state_;
  Factor().MakeExact();
  std::unique_ptr<InformationFactor> before = std::move(factor_);
  std::vector<int> all_withdrawn;
  for (int round = 0; round < options_.max_withdrawal_rounds; ++round) {
    // One observation of a feature a round: a wrong one pulls its feature, and with it the
    // feature's other observations past the gate until it is gone.
    std::unordered_set<int64_t> features_done;
    std::vector<int> withdrawn;
    for (const auto& [r2, k] : FailingObservations()) {
      const int64_t feature = taken_[k].observation.feature_id;
      if (features_done.count(feature) > 0 || !kept.Withdraw(k)) continue;
      features_done.insert(feature);
      withdrawn.push_back(k);
    }
    if (!kept.Connected()) {
      for (int k : withdrawn) kept.PutBack(k);
      withdrawn.clear();
    }
    if (withdrawn.empty()) break;
    for (int k : withdrawn) {
      taken_[k].withdrawn = true;
      AddTakenInformation(taken_[k], -1.0);
    }
    all_withdrawn.insert(all_withdrawn.end(), withdrawn.begin(), withdrawn.end());
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
    before.reset();
    try {
      InformationFactor& factor = Factor();
      factor.MakeExact();
      state_ = factor.Solve(info_vector_);
      stats.withdrawn = static_cast<int>(all_withdrawn.size());
    } catch (const DataError&) {
      // The rules above should prevent it; should it happen, they all go back in, and the
      // filter is as it was (its matrix and vector to rounding).
      for (int k : all_withdrawn) {
        AddTakenInformation(taken_[k], 1.0);
        taken_[k].withdrawn = false;
      }
      factor_.reset();
      Factor().MakeExact();
      state_ = state_before;
      stats.put_back = static_cast<int>(all_withdrawn.size());
    }
  }
  stats.still_failing = static_cast<int>(FailingObservations().size());
  stats.seconds = SecondsSince(start);
  return stats;
}

}  // namespace ieslam
