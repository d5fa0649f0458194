// Between exact factorisations of the pose Schur complement S: the state from conjugate
// gradients on S x_p = b, preconditioned with the last factor.
//
// A lazy update keeps the features' blocks exact and leaves S's factor L as it was: the
// poses added since (N, few) are eliminated exactly and L stands in for the rest,
//   M = [M_old + B C^-1 B^T, B; B^T, C]   (C = S_NN, B = S_old,N, M_old = L L^T),
// warm-started from the previous estimate. S - M = [S/C - M_old, 0; 0, 0], and S/C, the
// information on the old poses with everything else marginalised, only grows as
// observations come, so M <= S: CG's error has a computable bound (r^T M^-1 r >= e^T S e),
// and S is positive definite exactly when C is (the check an update needs). L is applied
// from its float copy (half the bytes to stream), while the residuals, S x and the iterates
// stay double; the bound then holds up to the float factor's relative error.
//
// The solver also keeps the costs that PoseSchurFactor's choice between a lazy and an exact
// update weighs: the flops the lazy updates since the last factorisation have cost beyond
// the first of them, and the CG iterations of the last solves.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "backend/pose_schur_blocks.h"
#include "backend/windowed_pose_cholesky.h"

namespace ieslam {

class LazyPoseSolver {
 public:
  // CG stops once sqrt(r^T M^-1 r), a bound on the error's Mahalanobis norm, is below
  // `cg_tolerance`, or after `cg_max_iterations`; its flops count `cg_flop_weight` times in
  // the cost it records.
  LazyPoseSolver(double cg_tolerance, int cg_max_iterations, double cg_flop_weight);

  // The preconditioner after a lazy update: C (S's block of the poses not in `factor`)
  // factored and B (their coupling with the factored poses) gathered, and the unfactored
  // poses placed in `factor`. False, changing nothing, if C is not positive definite, that
  // is (M_old being so) if S is not.
  bool Prepare(const PoseSchurBlocks& blocks, WindowedPoseCholesky* factor);
  // After a factorisation: no lazy poses, and no cost since.
  void Reset();

  // z = M^-1 z (M = S when `factor` is exact), with the double factor or its float copy.
  void ApplyPreconditioner(const WindowedPoseCholesky& factor, bool single,
                           Eigen::VectorXd* z) const;
  // I^-1 i by preconditioned CG from `guess` (a state vector; only its poses are read), with
  // the float copy of L (which must be up to date). False when CG has not converged in
  // cg_max_iterations (*x is then the last iterate).
  bool Solve(const PoseSchurBlocks& blocks, const WindowedPoseCholesky& factor,
             const Eigen::VectorXd& info_vector, const Eigen::VectorXd& guess, Eigen::VectorXd* x);
  // A solve by substitution instead: no CG iterations.
  void NoteSubstitution() { last_iterations_ = 0; }

  // Flops of one CG iteration: the two triangular solves and the product with S.
  static double IterationFlops(const PoseSchurBlocks& blocks, const WindowedPoseCholesky& factor);
  // Estimated flops of preparing the preconditioner for `lazy_n` unfactored dimensions.
  static double PreparationFlops(const PoseSchurBlocks& blocks, double lazy_n);

  // Estimated cost of the lazy updates since the last factorisation, beyond the first's.
  double lazy_flops() const { return lazy_flops_; }
  // CG iterations of the first lazy solve since the last factorisation (-1: none yet).
  int baseline_iterations() const { return baseline_iterations_; }
  // CG iterations of the last solve (0 when it substituted).
  int last_iterations() const { return last_iterations_; }

 private:
  double cg_tolerance_;
  int cg_max_iterations_;
  double cg_flop_weight_;
  // The poses not in L (positions from L's end on, equal to their indices): C = S's block of
  // them, factored, and B = S's block coupling them with the factored poses.
  Eigen::LLT<Eigen::MatrixXd> lazy_llt_;
  Eigen::MatrixXd lazy_B_;
  double lazy_flops_ = 0.0;
  int baseline_iterations_ = -1;
  int last_iterations_ = 0;
};

}  // namespace ieslam
