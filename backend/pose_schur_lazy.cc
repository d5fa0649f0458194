// PoseSchurFactor's lazy updates (pose_schur_factor.h): the choice between a lazy and an
// exact update, the preconditioner, conjugate gradients, and bringing S_ up to date before
// the next factorisation.
#include <algorithm>
#include <utility>

#include <glog/logging.h>
#include <Eigen/Cholesky>

#include "backend/pose_schur_factor.h"

namespace ieslam {

namespace {

double Square(double x) { return x * x; }

// v = (L L^T)^-1 v for a lower triangular L.
template <typename Matrix, typename Vector>
void SubstituteInPlace(const Matrix& L, Vector* v) {
  const auto lower = L.template triangularView<Eigen::Lower>();
  lower.solveInPlace(*v);
  lower.transpose().solveInPlace(*v);
}

}  // namespace

double PoseSchurFactor::RefactorFlops(int first, bool from_window) const {
  // The rank update forming the trailing block from S, and its factorisation.
  const double m = 6.0 * (num_poses() + 1 - first);
  return (from_window ? 0.0 : 0.5 * m * m * 6.0 * first) + m * m * m / 6.0;
}

PoseSchurFactor::Choice PoseSchurFactor::ChooseUpdate(const std::vector<int>& touched) const {
  const int k = num_poses();
  std::vector<int> dirty = DirtyPoses();
  for (const int pose : touched) {
    if (pose < static_cast<int>(order_.size())) dirty.push_back(pose);
  }
  // The exact update updates the window's C when it can, and refactors from the first
  // column that is not exact in double; renewing in float refactors from the first change.
  const Plan plan = PlanWindow(dirty);
  const bool fast = exact() && plan.first == window_start_;
  const double exact_flops = RefactorFlops(std::min(plan.first, double_columns_), fast);
  const double renew_flops = options_.single_speedup > 0.0
                                 ? RefactorFlops(plan.first, false) / options_.single_speedup
                                 : exact_flops;
  const double refactor_flops = std::min(exact_flops, renew_flops);
  // Of the lazy one: CG (as many iterations as last time) and the new poses' block C.
  const double lazy_n = 6.0 * (k + 1 - static_cast<int>(order_.size()));
  const double iteration = options_.cg_flop_weight * CgIterationFlops();
  const int expected = std::max(last_cg_iterations_, 1);
  const double prepare = LazyPreparationFlops(lazy_n);
  // Exact when refactoring costs less than the lazy solve (as in the first loop, where the
  // window keeps it small). Else lazy until the lazy updates since the last exact factor
  // have cost, beyond what they cost right after it (more iterations as the factor ages,
  // a growing block C), as much as refactoring: the ski-rental rule, within twice the
  // cost of the best schedule in hindsight.
  if (exact_flops <= expected * iteration + prepare) return Choice::kExact;
  const int excess = baseline_iterations_ < 0 ? 0 : std::max(expected - baseline_iterations_, 0);
  if (lazy_flops_ + excess * iteration + prepare < refactor_flops) return Choice::kLazy;
  return renew_flops < exact_flops ? Choice::kRenew : Choice::kExact;
}

double PoseSchurFactor::LazyPreparationFlops(double lazy_n) const {
  // Factoring C, and a 6x6 block product for each lazy observation and each other
  // observation of its feature.
  const double couplings = static_cast<double>(num_couplings_);
  const double per_pose = couplings / std::max(num_poses(), 1);
  const double per_feature = couplings / std::max<double>(features_.size(), 1.0);
  return lazy_n * lazy_n * lazy_n / 6.0 + 108.0 * lazy_n / 6.0 * per_pose * per_feature;
}

void PoseSchurFactor::Sync() {
  const int k = num_poses(), synced = synced_poses_;
  if (synced == k && unsynced_.empty()) return;
  Grow(6 * k);
  if (k > synced) {
    S_.block(6 * synced, 0, 6 * (k - synced), 6 * k).setZero();
    for (int pose = synced; pose < k; ++pose)
      S_.block<6, 6>(6 * pose, 6 * pose) = pose_blocks_[pose];
  }
  // Pairs of poses that S has seen: F_synced^-1 - F^-1; pairs with a new pose: -F^-1.
  const int count = static_cast<int>(unsynced_.size());
  std::vector<Eigen::Matrix3d> M(count, Eigen::Matrix3d::Zero());
  std::vector<std::vector<std::pair<int, int>>> seen_by(k);  // pose -> (unsynced_ slot, e)
  for (int slot = 0; slot < count; ++slot) {
    const Feature& feature = features_[unsynced_[slot]];
    if (feature.poses_synced > 0) {
      M[slot] = feature.F_inv_synced * (feature.F - feature.F_synced) * feature.F_inv;
      M[slot] = 0.5 * (M[slot] + M[slot].transpose());
    }
    for (size_t e = 0; e < feature.poses.size(); ++e) {
      seen_by[feature.poses[e]].emplace_back(slot, static_cast<int>(e));
    }
  }
  // The blocks below the diagonal only (S_ keeps no others; a feature's poses are
  // increasing), a pose's columns at a time: they stay in cache while every feature it saw
  // adds to them (each block still sums its features in the order of unsynced_).
  for (int pose = 0; pose < k; ++pose) {
    for (const auto& [slot, j] : seen_by[pose]) {
      const Feature& feature = features_[unsynced_[slot]];
      const int a = feature.poses_synced, p = static_cast<int>(feature.poses.size());
      const Eigen::Matrix<double, 3, 6> MBt = M[slot] * feature.couplings[j].transpose();
      const Eigen::Matrix<double, 3, 6> FBt = feature.F_inv * feature.couplings[j].transpose();
      for (int i = j; i < p; ++i) {
        Eigen::Matrix<double, 6, 6> block;
        if (i < a) {
          block.noalias() = feature.couplings[i] * MBt;
        } else {
          block.noalias() = -feature.couplings[i] * FBt;
        }
        S_.block<6, 6>(6 * feature.poses[i], 6 * pose) += block;
      }
    }
  }
  for (const int index : unsynced_) {
    Feature& feature = features_[index];
    feature.F_synced = feature.F;
    feature.F_inv_synced = feature.F_inv;
    feature.poses_synced = static_cast<int>(feature.poses.size());
    feature.unsynced = false;
  }
  unsynced_.clear();
  synced_poses_ = k;
}

bool PoseSchurFactor::PrepareLazyPreconditioner() {
  const int factored = static_cast<int>(order_.size());
  const int old_n = 6 * factored, lazy_n = dim() - old_n;
  // S's blocks of the poses not in L, from the features (S itself is not kept up to date
  // by lazy updates): C = S_NN and B = S_old,N, for M = [M_old + B C^-1 B^T, B; B^T, C].
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(lazy_n, lazy_n);
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(old_n, lazy_n);
  for (int pose = factored; pose < num_poses(); ++pose) {
    C.block<6, 6>(6 * (pose - factored), 6 * (pose - factored)) = pose_blocks_[pose];
  }
  // The features the lazy poses saw, in index order.
  const int first_lazy = factored > 0 ? pose_coupling_ends_[factored - 1] : 0;
  std::vector<int> seen(pose_coupling_features_.begin() + first_lazy,
                        pose_coupling_features_.end());
  std::sort(seen.begin(), seen.end());
  seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
  for (const int index : seen) {
    const Feature& feature = features_[index];
    const int p = static_cast<int>(feature.poses.size());
    // Poses are appended in order: the lazy poses' observations come last.
    for (int e = p - 1; e >= 0 && feature.poses[e] >= factored; --e) {
      const Eigen::Matrix<double, 3, 6> V = feature.F_inv * feature.couplings[e].transpose();
      const int col = 6 * (feature.poses[e] - factored);
      for (int i = 0; i < p; ++i) {
        const int pose = feature.poses[i];
        if (pose >= factored) {
          C.block<6, 6>(6 * (pose - factored), col).noalias() -= feature.couplings[i] * V;
        } else {
          B.block<6, 6>(6 * position_[pose], col).noalias() -= feature.couplings[i] * V;
        }
      }
    }
  }
  Eigen::LLT<Eigen::MatrixXd> llt(C);
  if (llt.info() != Eigen::Success || !(llt.matrixLLT().diagonal().minCoeff() > 0.0)) return false;
  lazy_llt_ = std::move(llt);
  lazy_B_ = std::move(B);
  position_.resize(num_poses());
  for (int pose = factored; pose < num_poses(); ++pose) position_[pose] = pose;
  lazy_flops_ += LazyPreparationFlops(lazy_n);
  return true;
}

void PoseSchurFactor::ApplyPreconditioner(bool single, Eigen::VectorXd* z) const {
  // Block elimination of M = [M_old + B C^-1 B^T, B; B^T, C], the lazy poses first.
  const int old_n = 6 * static_cast<int>(order_.size()), lazy_n = dim() - old_n;
  auto z_old = z->head(old_n);
  auto z_lazy = z->tail(lazy_n);
  Eigen::VectorXd y;
  if (lazy_n > 0) {
    y = lazy_llt_.solve(z_lazy);
    z_old.noalias() -= lazy_B_ * y;
  }
  if (old_n > 0 && single) {
    Eigen::VectorXf w = z_old.cast<float>();
    SubstituteInPlace(L_single_.topLeftCorner(old_n, old_n), &w);
    z_old = w.cast<double>();
  } else if (old_n > 0) {
    SubstituteInPlace(L_.topLeftCorner(old_n, old_n), &z_old);
  }
  if (lazy_n > 0) z_lazy = y - lazy_llt_.solve(lazy_B_.transpose() * z_old);
}

void PoseSchurFactor::MultiplyS(const Eigen::VectorXd& x, Eigen::VectorXd* y) const {
  // u_f = E_f x, then y = I_pp x - E^T F^-1 u, pose by pose.
  Eigen::Matrix3Xd u = Eigen::Matrix3Xd::Zero(3, features_.size());
  int e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    const auto x_pose = x.segment<6>(6 * position_[pose]);
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      u.col(pose_coupling_features_[e]).noalias() += pose_couplings_[e].transpose() * x_pose;
    }
  }
  for (size_t f = 0; f < features_.size(); ++f) {
    const Eigen::Vector3d v = features_[f].F_inv * u.col(f);
    u.col(f) = v;
  }
  y->resize(dim());
  e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    const int row = 6 * position_[pose];
    auto y_pose = y->segment<6>(row);
    y_pose.noalias() = pose_blocks_[pose] * x.segment<6>(row);
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      y_pose.noalias() -= pose_couplings_[e] * u.col(pose_coupling_features_[e]);
    }
  }
}

double PoseSchurFactor::CgIterationFlops() const {
  const double old_n = 6.0 * static_cast<double>(order_.size());
  return Square(old_n) + 4.0 * old_n * (dim() - old_n) + 72.0 * static_cast<double>(num_couplings_);
}

bool PoseSchurFactor::SolveIteratively(const Eigen::VectorXd& info_vector,
                                       const Eigen::VectorXd& guess, Eigen::VectorXd* x) {
  CHECK(valid_) << "no valid factor";
  last_cg_iterations_ = 0;
  if (exact()) {
    *x = Solve(info_vector);
    return true;
  }
  // Preconditioned conjugate gradients on S x_p = b. With M <= S, r^T M^-1 r >=
  // r^T S^-1 r = e^T S e: the stopping test bounds the error's Mahalanobis norm (M from
  // the float copy of L: up to float's relative precision).
  SyncSingle();
  const Eigen::VectorXd b = ReducedRhs(info_vector);
  Eigen::VectorXd x_p(dim());
  for (int pose = 0; pose < num_poses(); ++pose) {
    x_p.segment<6>(6 * position_[pose]) = guess.segment<6>(pose_offsets_[pose]);
  }
  Eigen::VectorXd q;
  MultiplyS(x_p, &q);
  Eigen::VectorXd r = b - q;
  Eigen::VectorXd z = r;
  ApplyPreconditioner(/*single=*/true, &z);
  double rz = r.dot(z);
  Eigen::VectorXd p = z;
  const double tolerance = Square(options_.cg_tolerance);
  int iterations = 0;
  while (!(rz <= tolerance) && iterations < options_.cg_max_iterations) {
    MultiplyS(p, &q);
    const double pq = p.dot(q);
    if (!(pq > 0.0)) break;
    const double alpha = rz / pq;
    x_p += alpha * p;
    r -= alpha * q;
    z = r;
    ApplyPreconditioner(/*single=*/true, &z);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
    ++iterations;
  }
  // The baseline is the first lazy solve's: right after a renewal in float, with no lazy
  // poses, CG needs fewer iterations than any lazy update will.
  const bool after_lazy_update = static_cast<int>(order_.size()) < num_poses();
  last_cg_iterations_ = iterations;
  if (after_lazy_update && baseline_iterations_ < 0) baseline_iterations_ = iterations;
  if (baseline_iterations_ >= 0) {
    lazy_flops_ += options_.cg_flop_weight * std::max(iterations - baseline_iterations_, 0) *
                   CgIterationFlops();
  }
  *x = FullState(info_vector, x_p);
  return rz <= tolerance;
}

}  // namespace ieslam
