#include "backend/sparse_information_factor.h"

#include <chrono>
#include <map>
#include <vector>

#include <glog/logging.h>

#include "backend/upper_column_storage.h"
#include "core/stopwatch.h"

namespace ieslam {

namespace {

// The re-observed features' diagonal blocks: a low-rank update of the factor.
std::vector<DiagonalIncrement> Increments(const InformationUpdate& update) {
  std::vector<DiagonalIncrement> increments;
  for (const ObservationBlocks& obs : update.observations) {
    if (!obs.is_new) increments.push_back({obs.feature_offset, obs.I_ff});
  }
  return increments;
}

// The earlier poses' diagonal blocks (features entering on a later sighting), one sum per
// pose in offset order.
std::vector<PoseIncrement> PoseIncrements(const InformationUpdate& update) {
  std::map<int, Eigen::Matrix<double, 6, 6>> sums;
  for (const ObservationBlocks& obs : update.observations) {
    for (const EarlierSightingBlocks& earlier : obs.earlier) {
      auto [it, added] = sums.try_emplace(earlier.pose_offset, earlier.I_cc);
      if (!added) it->second += earlier.I_cc;
    }
  }
  std::vector<PoseIncrement> increments;
  for (const auto& [offset, block] : sums) increments.push_back({offset, block});
  return increments;
}

class SparseInformationFactor final : public WrappedInformationFactor<SparseCholesky> {
 public:
  explicit SparseInformationFactor(const SparseCholeskyOptions& options)
      : WrappedInformationFactor(options) {}

  FactorStatus AddAndSolve(const UpperColumnStorage& matrix, const InformationUpdate& update,
                           bool /*keep_exact*/, const Eigen::VectorXd& info_vector,
                           const Eigen::VectorXd& /*guess*/, Eigen::VectorXd* state) override {
    // In place when the factor has room (the re-observed features' blocks are a low-rank
    // update, the new variables new rows), else a fresh ordering and factorisation.
    if (!factor_.Update(matrix, update.old_dim, Increments(update), PoseIncrements(update)) &&
        !factor_.Factorize(matrix, /*pattern_changed=*/true)) {
      return FactorStatus::kNotPositiveDefinite;
    }
    NoteFactorTimings();
    const auto solve_start = std::chrono::steady_clock::now();
    *state = factor_.Solve(info_vector);  // eq. 10: I X = i
    timings_.solve_s = SecondsSince(solve_start);
    return FactorStatus::kOk;
  }

  void AddDeferred(const UpperColumnStorage& /*matrix*/, const InformationUpdate& update) override {
    factor_.NoteUpdate(update.old_dim, Increments(update), PoseIncrements(update));
    timings_ = FactorTimings();
  }

  void Restore(const UpperColumnStorage& matrix, bool factored) override {
    // A failed in-place update leaves no factor; Factorize keeps the old one otherwise.
    if (!factor_.valid() && matrix.dim() > 0 && factored) {
      CHECK(factor_.Factorize(matrix, /*pattern_changed=*/true)) << "the old matrix refactors";
    }
  }

  bool Refactor(const UpperColumnStorage& matrix) override {
    if (!factor_.Factorize(matrix, /*pattern_changed=*/true)) return false;
    NoteFactorTimings();
    return true;
  }

  void MakeExact() override {}
  bool uses_pose_schur() const override { return false; }

 private:
  // The analysis and factorisation times of the last factor change.
  void NoteFactorTimings() {
    timings_ = FactorTimings();
    timings_.analyze_s = factor_.timings().analyze_s;
    timings_.factorize_s = factor_.timings().factorize_s;
  }
};

}  // namespace

std::unique_ptr<InformationFactor> MakeSparseInformationFactor(
    const SparseCholeskyOptions& options) {
  return std::make_unique<SparseInformationFactor>(options);
}

}  // namespace ieslam
