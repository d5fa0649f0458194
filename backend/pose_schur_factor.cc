#include "backend/pose_schur_factor.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include <glog/logging.h>

#include "core/error.h"

namespace ieslam {

namespace {

const PoseSchurOptions& Checked(const PoseSchurOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("PoseSchurOptions: " + why);
  return options;
}

}  // namespace

bool PoseSchurOptions::Check(std::string* why) const {
  std::ostringstream reason;
  if (prefetch < 0) {
    reason << "prefetch must be >= 0, got " << prefetch;
  } else if (evict_after < 1) {
    reason << "evict_after must be >= 1, got " << evict_after;
  } else if (!(cg_tolerance > 0.0) || !std::isfinite(cg_tolerance)) {
    reason << "cg_tolerance must be positive and finite, got " << cg_tolerance;
  } else if (cg_max_iterations < 1) {
    reason << "cg_max_iterations must be >= 1, got " << cg_max_iterations;
  } else if (!(cg_flop_weight >= 0.0) || !std::isfinite(cg_flop_weight)) {
    reason << "cg_flop_weight must be >= 0 and finite, got " << cg_flop_weight;
  } else if (!(single_speedup >= 0.0) || !std::isfinite(single_speedup)) {
    reason << "single_speedup must be >= 0 and finite, got " << single_speedup;
  }
  if (why != nullptr) *why = reason.str();
  return reason.str().empty();
}

PoseSchurFactor::PoseSchurFactor(const PoseSchurOptions& options)
    : options_(Checked(options)),
      factor_(options_.prefetch, options_.evict_after),
      lazy_(options_.cg_tolerance, options_.cg_max_iterations, options_.cg_flop_weight) {}

void PoseSchurFactor::Grow(int n) {
  if (blocks_.capacity() >= n) return;
  // A quarter more room (ten poses at least): a copy costs one pass over S and its factor,
  // far less than the updates between copies, and past 40 poses at most a fifth of their rows
  // and columns stay unused.
  const int capacity = n + std::max(60, n / 4);
  blocks_.Reserve(capacity);
  factor_.Reserve(capacity);
}

void PoseSchurFactor::Sync() {
  Grow(blocks_.dim());
  blocks_.Sync();
}

bool PoseSchurFactor::AddPose(int pose_offset, const Eigen::Matrix<double, 6, 6>& I_pp,
                              const std::vector<ObservationBlocks>& observations,
                              SchurUpdate update) {
  CHECK(!blocks_.HasPoseAt(pose_offset)) << "pose offset " << pose_offset << " taken";
  const bool was_exact = exact();
  std::vector<int> touched = blocks_.TouchedPoses(observations);
  const bool chosen = update == SchurUpdate::kLazy && valid() && !touched.empty();
  const Choice choice = chosen ? ChooseUpdate(touched) : Choice::kExact;
  // A renewal, or an exact update that refactors from S (not from the window's C), takes
  // the update in lazily first (checking that S stays positive definite), then brings S up
  // to date in one pass over the features this and the lazy updates changed.
  const bool lazy = chosen && (choice != Choice::kExact || !was_exact);
  // Anything else changes S itself: first the lazy updates' changes.
  if (!lazy) Sync();
  const PoseSchurBlocks::Change change =
      blocks_.ComputeChange(I_pp, observations, std::move(touched), /*of_S=*/!lazy);
  if (!lazy) Grow(blocks_.dim() + 6);
  // Build, then commit only if the factor takes it: the blocks and the touch record are
  // taken back exactly otherwise.
  const PoseSchurBlocks::Undo undo =
      blocks_.AddPose(pose_offset, I_pp, observations, change, /*update_S=*/!lazy);
  const std::vector<int> last_touched = factor_.AddPose(change.touched);
  if (FactorAddition(update, choice, lazy, was_exact, change)) return true;
  factor_.RemoveLastPose(change.touched, last_touched);
  blocks_.Revert(undo);
  return false;
}

bool PoseSchurFactor::FactorAddition(SchurUpdate update, Choice choice, bool lazy, bool was_exact,
                                     const PoseSchurBlocks::Change& change) {
  if (update == SchurUpdate::kDefer) {
    factor_.Invalidate();
    return true;
  }
  if (!valid()) return Refactor();
  if (lazy) {
    if (!lazy_.Prepare(blocks_, &factor_)) return false;  // S is not positive definite
    if (choice != Choice::kLazy) {
      Sync();
      const WindowedPoseCholesky::Plan plan = factor_.PlanWindow(factor_.DirtyPoses());
      // Should both fail (S numerically indefinite), the lazy preconditioner stays.
      if (choice != Choice::kRenew || !RenewInSingle(plan)) FactorFrom(plan, nullptr);
    }
    return true;
  }
  const WindowedPoseCholesky::Plan plan = factor_.PlanWindow(factor_.DirtyPoses());
  if (was_exact && plan.first == factor_.window_start()) {
    const Eigen::MatrixXd T = factor_.UpdatedWindow(plan, change.local, change.D);
    return FactorFrom(plan, &T);
  }
  return FactorFrom(plan, nullptr);
}

bool PoseSchurFactor::FactorFrom(const WindowedPoseCholesky::Plan& plan,
                                 const Eigen::MatrixXd* trailing) {
  Grow(blocks_.dim());
  if (!factor_.FactorFrom(plan, blocks_.S(), trailing)) return false;
  lazy_.Reset();
  return true;
}

bool PoseSchurFactor::RenewInSingle(const WindowedPoseCholesky::Plan& plan) {
  Grow(blocks_.dim());
  if (!factor_.RenewInSingle(plan, blocks_.S())) return false;
  lazy_.Reset();
  return true;
}

bool PoseSchurFactor::Refactor() {
  Sync();
  return FactorFrom(factor_.PlanAll(), nullptr);
}

bool PoseSchurFactor::MakeExact() {
  CHECK(valid()) << "no factor to make exact";
  if (exact()) return true;
  Sync();
  return FactorFrom(factor_.PlanWindow(factor_.DirtyPoses()), nullptr);
}

double PoseSchurFactor::RefactorFlops(int first, bool from_window) const {
  // The rank update forming the trailing block from S, and its factorisation.
  const double m = 6.0 * (num_poses() + 1 - first);
  return (from_window ? 0.0 : 0.5 * m * m * 6.0 * first) + m * m * m / 6.0;
}

PoseSchurFactor::Choice PoseSchurFactor::ChooseUpdate(const std::vector<int>& touched) const {
  const int k = num_poses();
  std::vector<int> dirty = factor_.DirtyPoses();
  for (const int pose : touched) {
    if (pose < factor_.num_factored()) dirty.push_back(pose);
  }
  // The exact update updates the window's C when it can, and refactors from the first
  // column that is not exact in double; renewing in float refactors from the first change.
  const WindowedPoseCholesky::Plan plan = factor_.PlanWindow(dirty);
  const bool fast = exact() && plan.first == factor_.window_start();
  const double exact_flops = RefactorFlops(std::min(plan.first, factor_.double_columns()), fast);
  const double renew_flops = options_.single_speedup > 0.0
                                 ? RefactorFlops(plan.first, false) / options_.single_speedup
                                 : exact_flops;
  const double refactor_flops = std::min(exact_flops, renew_flops);
  // Of the lazy one: CG (as many iterations as last time) and the new poses' block C.
  const double lazy_n = 6.0 * (k + 1 - factor_.num_factored());
  const double iteration =
      options_.cg_flop_weight * LazyPoseSolver::IterationFlops(blocks_, factor_);
  const int expected = std::max(lazy_.last_iterations(), 1);
  const double prepare = LazyPoseSolver::PreparationFlops(blocks_, lazy_n);
  // Exact when refactoring costs less than the lazy solve (as in the first loop, where the
  // window keeps it small). Else lazy until the lazy updates since the last exact factor
  // have cost, beyond what they cost right after it (more iterations as the factor ages,
  // a growing block C), as much as refactoring: the ski-rental rule, within twice the
  // cost of the best schedule in hindsight.
  if (exact_flops <= expected * iteration + prepare) return Choice::kExact;
  const int baseline = lazy_.baseline_iterations();
  const int excess = baseline < 0 ? 0 : std::max(expected - baseline, 0);
  if (lazy_.lazy_flops() + excess * iteration + prepare < refactor_flops) return Choice::kLazy;
  return renew_flops < exact_flops ? Choice::kRenew : Choice::kExact;
}

Eigen::VectorXd PoseSchurFactor::Solve(const Eigen::VectorXd& info_vector) const {
  CHECK(exact()) << "no exact factor";
  Eigen::VectorXd x_p = blocks_.ReducedRhs(info_vector, factor_.position());
  lazy_.ApplyPreconditioner(factor_, /*single=*/false, &x_p);
  return blocks_.FullState(info_vector, x_p, factor_.position());
}

bool PoseSchurFactor::SolveIteratively(const Eigen::VectorXd& info_vector,
                                       const Eigen::VectorXd& guess, Eigen::VectorXd* x) {
  CHECK(valid()) << "no valid factor";
  if (exact()) {
    lazy_.NoteSubstitution();
    *x = Solve(info_vector);
    return true;
  }
  factor_.SyncSingle();
  return lazy_.Solve(blocks_, factor_, info_vector, guess, x);
}

double PoseSchurFactor::LogDet() const {
  CHECK(exact()) << "no exact factor";
  return blocks_.FeatureLogDet() + factor_.LogDetS();
}

Eigen::MatrixXd PoseSchurFactor::InverseSubmatrix(const std::vector<int>& indices) const {
  CHECK(exact()) << "no exact factor";
  const PoseSchurBlocks::InverseColumns columns = blocks_.ColumnsOf(indices, factor_.position());
  Eigen::MatrixXd result = factor_.QuadraticForm(columns.R, columns.first_row);
  blocks_.AddFeatureInverses(columns, &result);
  return result;
}

int64_t PoseSchurFactor::FactorNonzeros() const {
  const int64_t n = blocks_.dim();
  return n * (n + 1) / 2 + 6 * static_cast<int64_t>(blocks_.num_features());
}

}  // namespace ieslam
