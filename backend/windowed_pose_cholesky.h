// The dense Cholesky factor of the pose Schur complement S (backend/pose_schur_blocks.h),
// ordered so that the poses the updates touch form a trailing window W.
//
// With S's factor L = [L_ll 0; L_wl L_ww], C = S_ww - L_wl L_wl^T is kept, so an update that
// touches only W adds its change to C and refactors C alone (|W|^3 / 3 flops, dense blocked).
// A touched pose outside W is moved in together with its neighbours in time (the trajectory
// will likely revisit them next), and the factor is recomputed from the first moved
// position; poses untouched for a while leave W at its front, which costs nothing extra.
//
// A float copy of L serves conjugate gradients as a preconditioner (backend/lazy_pose_
// solver.h): renewing it in float (RenewInSingle) leaves the double factor exact only in the
// leading columns it did not touch (double_columns()), which a later exact factorisation
// starts from.
//
// The factor also keeps the record of which update last touched each pose, which the window
// follows. Positions are in poses (6 scalars each); "pose index" is the order added.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace ieslam {

class WindowedPoseCholesky {
 public:
  // A new order of the factor's positions: from `first` on it changes.
  struct Plan {
    int first = 0;
    std::vector<int> order;  // position -> pose index
    int window_start = 0;
  };

  // `prefetch`: a pose moved into the window brings the poses within this many places of it
  // in the order added; `evict_after`: poses not touched by this many updates leave it.
  WindowedPoseCholesky(int prefetch, int evict_after);

  // Records an added pose and the update that touched `touched`; returns their previous
  // records, for RemoveLastPose.
  std::vector<int> AddPose(const std::vector<int>& touched);
  // Takes the last AddPose back (`previous`: what it returned).
  void RemoveLastPose(const std::vector<int>& touched, const std::vector<int>& previous);
  int num_poses() const { return static_cast<int>(last_touched_.size()); }

  // Factored poses touched by an update since the last factorisation.
  std::vector<int> DirtyPoses() const;
  // Moves the `touched` poses outside the window into it (with their neighbours in time),
  // evicts the poses untouched for a while, and appends the poses not yet factored.
  Plan PlanWindow(const std::vector<int>& touched) const;
  // Every pose, the recently touched ones in the window.
  Plan PlanAll() const;
  // The exact trailing block for `plan` when it moves nothing in (plan.first ==
  // window_start(), the factor exact): C plus the update `D` of the pose just added (D's
  // rows: `local` of the touched poses, then the new pose).
  Eigen::MatrixXd UpdatedWindow(const Plan& plan, const std::vector<int>& local,
                                const Eigen::MatrixXd& D) const;

  // Refactors S (pose order, lower 6x6 blocks) from position plan.first on for the new
  // order; positions before it keep their poses and columns of L. `trailing`: the Schur
  // complement of the positions from plan.first when known (C plus the update); else it is
  // formed from S and L's leading columns. False, changing nothing, if not positive definite.
  bool FactorFrom(const Plan& plan, const Eigen::MatrixXd& S, const Eigen::MatrixXd* trailing);
  // The same in float, into the float copy only: a preconditioner (no C, no exact factor);
  // the double factor keeps its leading columns (rows moved). False, changing nothing, if
  // the float factorisation fails.
  bool RenewInSingle(const Plan& plan, const Eigen::MatrixXd& S);
  // Brings the float copy's rows up to date with the double factor.
  void SyncSingle();
  // L keeps room for `capacity` scalar rows and columns (its contents are kept).
  void Reserve(int capacity);
  // Lazy updates: the poses from num_factored() on, not in L, get positions equal to their
  // indices.
  void PlaceUnfactored();
  // Deferred additions: no factor until the next FactorFrom.
  void Invalidate() { valid_ = false; }

  // L factors S, or (after lazy updates) S as it was for the poses then.
  bool valid() const { return valid_; }
  // L L^T = S, in double.
  bool exact() const {
    return valid_ && num_factored() == num_poses() && double_columns_ == num_factored();
  }
  int num_factored() const { return static_cast<int>(order_.size()); }
  int double_columns() const { return double_columns_; }
  int window_start() const { return window_start_; }
  // Pose index -> position.
  const std::vector<int>& position() const { return position_; }

  // z = (L L^T)^-1 z on the factored positions (z.size() == 6 num_factored()), with the
  // double factor or its float copy.
  void Substitute(Eigen::Ref<Eigen::VectorXd> z, bool single) const;
  // log det S = 2 sum log diag L. Needs exact().
  double LogDetS() const;
  // R^T S^-1 R for columns R in factor positions, each zero above its `first_row`: the
  // columns, sorted by that row, are solved against L in groups, each from its group's first
  // row down, and the products run over the rows where both can be nonzero. Needs exact().
  Eigen::MatrixXd QuadraticForm(const Eigen::MatrixXd& R, const std::vector<int>& first_row) const;

 private:
  int dim() const { return 6 * num_poses(); }
  // The new order and window after a factorisation.
  void Commit(const std::vector<int>& order, int window_start);

  int prefetch_;
  int evict_after_;
  std::vector<int> last_touched_;  // pose index -> update count
  int updates_ = 0;
  int exact_since_update_ = 0;  // updates_ at the last factorisation
  Eigen::MatrixXd L_;           // order_ (positions), lower triangle
  Eigen::MatrixXd C_;           // trailing Schur complement of the window (window positions)
  Eigen::MatrixXf L_single_;    // float L: CG's preconditioner (allocated on first use)
  int double_columns_ = 0;      // L_'s leading columns (in poses) that are exact
  int single_rows_ = 0;         // L_single_'s leading rows (in poses) that are up to date
  std::vector<int> order_;      // position (pose slot) -> pose index
  std::vector<int> position_;   // pose index -> position
  int window_start_ = 0;        // first window position (in poses)
  bool valid_ = false;
};

}  // namespace ieslam
