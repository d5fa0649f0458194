#include "backend/lazy_pose_solver.h"

#include <algorithm>
#include <utility>

#include <glog/logging.h>

namespace ieslam {

namespace {

double Square(double x) { return x * x; }

}  // namespace

LazyPoseSolver::LazyPoseSolver(double cg_tolerance, int cg_max_iterations, double cg_flop_weight)
    : cg_tolerance_(cg_tolerance),
      cg_max_iterations_(cg_max_iterations),
      cg_flop_weight_(cg_flop_weight) {}

bool LazyPoseSolver::Prepare(const PoseSchurBlocks& blocks, WindowedPoseCholesky* factor) {
  const int lazy_n = blocks.dim() - 6 * factor->num_factored();
  // From the blocks: S itself is not kept up to date by lazy updates.
  Eigen::MatrixXd C, B;
  blocks.SchurBlocksOfPoses(factor->num_factored(), factor->position(), &C, &B);
  Eigen::LLT<Eigen::MatrixXd> llt(C);
  if (llt.info() != Eigen::Success || !(llt.matrixLLT().diagonal().minCoeff() > 0.0)) return false;
  lazy_llt_ = std::move(llt);
  lazy_B_ = std::move(B);
  factor->PlaceUnfactored();
  lazy_flops_ += PreparationFlops(blocks, lazy_n);
  return true;
}

void LazyPoseSolver::Reset() {
  lazy_B_.resize(0, 0);
  lazy_flops_ = 0.0;
  baseline_iterations_ = -1;
}

double LazyPoseSolver::PreparationFlops(const PoseSchurBlocks& blocks, double lazy_n) {
  // Factoring C, and a 6x6 block product for each lazy observation and each other
  // observation of its feature.
  const double couplings = static_cast<double>(blocks.num_couplings());
  const double per_pose = couplings / std::max(blocks.num_poses(), 1);
  const double per_feature = couplings / std::max<double>(blocks.num_features(), 1.0);
  return lazy_n * lazy_n * lazy_n / 6.0 + 108.0 * lazy_n / 6.0 * per_pose * per_feature;
}

double LazyPoseSolver::IterationFlops(const PoseSchurBlocks& blocks,
                                      const WindowedPoseCholesky& factor) {
  const double old_n = 6.0 * static_cast<double>(factor.num_factored());
  return Square(old_n) + 4.0 * old_n * (blocks.dim() - old_n) +
         72.0 * static_cast<double>(blocks.num_couplings());
}

void LazyPoseSolver::ApplyPreconditioner(const WindowedPoseCholesky& factor, bool single,
                                         Eigen::VectorXd* z) const {
  // Block elimination of M = [M_old + B C^-1 B^T, B; B^T, C], the lazy poses first.
  const int old_n = 6 * factor.num_factored(), lazy_n = static_cast<int>(z->size()) - old_n;
  auto z_old = z->head(old_n);
  auto z_lazy = z->tail(lazy_n);
  Eigen::VectorXd y;
  if (lazy_n > 0) {
    y = lazy_llt_.solve(z_lazy);
    z_old.noalias() -= lazy_B_ * y;
  }
  if (old_n > 0) factor.Substitute(z_old, single);
  if (lazy_n > 0) z_lazy = y - lazy_llt_.solve(lazy_B_.transpose() * z_old);
}

bool LazyPoseSolver::Solve(const PoseSchurBlocks& blocks, const WindowedPoseCholesky& factor,
                           const Eigen::VectorXd& info_vector, const Eigen::VectorXd& guess,
                           Eigen::VectorXd* x) {
  // Preconditioned conjugate gradients on S x_p = b.
  const std::vector<int>& position = factor.position();
  const Eigen::VectorXd b = blocks.ReducedRhs(info_vector, position);
  Eigen::VectorXd x_p(blocks.dim());
  for (int pose = 0; pose < blocks.num_poses(); ++pose) {
    x_p.segment<6>(6 * position[pose]) = guess.segment<6>(blocks.pose_offset(pose));
  }
  Eigen::VectorXd q;
  blocks.MultiplyS(x_p, position, &q);
  Eigen::VectorXd r = b - q;
  Eigen::VectorXd z = r;
  ApplyPreconditioner(factor, /*single=*/true, &z);
  double rz = r.dot(z);
  Eigen::VectorXd p = z;
  const double tolerance = Square(cg_tolerance_);
  int iterations = 0;
  while (!(rz <= tolerance) && iterations < cg_max_iterations_) {
    blocks.MultiplyS(p, position, &q);
    const double pq = p.dot(q);
    if (!(pq > 0.0)) break;
    const double alpha = rz / pq;
    x_p += alpha * p;
    r -= alpha * q;
    z = r;
    ApplyPreconditioner(factor, /*single=*/true, &z);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
    ++iterations;
  }
  // The baseline is the first lazy solve's: right after a renewal in float, with no lazy
  // poses, CG needs fewer iterations than any lazy update will.
  const bool after_lazy_update = factor.num_factored() < blocks.num_poses();
  last_iterations_ = iterations;
  if (after_lazy_update && baseline_iterations_ < 0) baseline_iterations_ = iterations;
  if (baseline_iterations_ >= 0) {
    lazy_flops_ += cg_flop_weight_ * std::max(iterations - baseline_iterations_, 0) *
                   IterationFlops(blocks, factor);
  }
  *x = blocks.FullState(info_vector, x_p, position);
  return rz <= tolerance;
}

}  // namespace ieslam
