#include "backend/pose_schur_information_factor.h"

#include <chrono>
#include <vector>

#include <glog/logging.h>

#include "backend/upper_column_storage.h"
#include "core/stopwatch.h"

namespace ieslam {

namespace {

class PoseSchurInformationFactor final : public WrappedInformationFactor<PoseSchurFactor> {
 public:
  explicit PoseSchurInformationFactor(const PoseSchurOptions& options)
      : WrappedInformationFactor(options) {}

  FactorStatus AddAndSolve(const UpperColumnStorage& matrix, const InformationUpdate& update,
                           bool keep_exact, const Eigen::VectorXd& info_vector,
                           const Eigen::VectorXd& guess, Eigen::VectorXd* state) override {
    const auto start = std::chrono::steady_clock::now();
    timings_ = FactorTimings();
    const SchurUpdate mode = keep_exact ? SchurUpdate::kExact : SchurUpdate::kLazy;
    if (!factor_.AddPose(matrix.dim() - 6, update.pose_block, update.observations, mode)) {
      return FactorStatus::kNotPositiveDefinite;
    }
    timings_.factorize_s = SecondsSince(start);
    const auto solve_start = std::chrono::steady_clock::now();
    bool solved = factor_.SolveIteratively(info_vector, guess, state);
    timings_.cg_iterations = factor_.last_cg_iterations();
    if (!solved && factor_.MakeExact()) {
      *state = factor_.Solve(info_vector);
      solved = true;
    }
    timings_.solve_s = SecondsSince(solve_start);
    return solved ? FactorStatus::kOk : FactorStatus::kUnsolved;
  }

  void AddDeferred(const UpperColumnStorage& matrix, const InformationUpdate& update) override {
    CHECK(factor_.AddPose(matrix.dim() - 6, update.pose_block, update.observations,
                          SchurUpdate::kDefer));
    timings_ = FactorTimings();
  }

  void Restore(const UpperColumnStorage& /*matrix*/, bool /*factored*/) override {}

  bool Refactor(const UpperColumnStorage& /*matrix*/) override {
    const auto start = std::chrono::steady_clock::now();
    timings_ = FactorTimings();
    if (!factor_.Refactor()) return false;
    timings_.factorize_s = SecondsSince(start);
    return true;
  }

  void MakeExact() override {
    CHECK(factor_.MakeExact()) << "the pose Schur complement is numerically not positive definite";
  }
  bool uses_pose_schur() const override { return true; }
};

}  // namespace

std::unique_ptr<InformationFactor> MakePoseSchurInformationFactor(const PoseSchurOptions& options) {
  return std::make_unique<PoseSchurInformationFactor>(options);
}

}  // namespace ieslam
