// The EIF's information matrix factored through its pose Schur complement: an exact
// alternative to the sparse Cholesky factor for problems with few poses and a dense pose
// block.
//
// The features' 3x3 blocks F_f eliminate one by one (backend/pose_schur_blocks.h): with
// S = I_pp - sum_f E_f^T F_f^-1 E_f, I X = i is solved by S x_p = i_p - sum E^T F^-1 i_f,
// then x_f = F^-1 (i_f - E_f x_p); log det I = sum log det F_f + log det S.
//
// Why: when a trajectory comes back (the paper's second loop, Zhou et al. 2008, §VI-A) S
// fills in completely, and each update re-observes ~100 features seen from poses of both
// loops, a rank-~300 change of S. A sparse factor pays that change along paths through the
// whole pose block, at CHOLMOD's row-by-row speed; here S is dense and its factor keeps the
// poses the updates touch in a trailing window (backend/windowed_pose_cholesky.h), so most
// updates refactor that window alone.
//
// Lazy updates (SchurUpdate::kLazy). An update of the second loop still touches poses of
// the first and refactors most of S, O(P^3); but an update only needs I X = i solved, and
// log det and covariances are asked for far less often. So a lazy update keeps the
// features' blocks exact, leaves S and its factor as they were (S catches up before the
// next factorisation, each changed feature once), and the state comes from conjugate
// gradients preconditioned with the old factor (backend/lazy_pose_solver.h). The factor is
// made exact (MakeExact, refactoring from the first old pose the lazy updates touched) when
// a query needs it, or when CG does not converge. An update is made exactly when that costs
// less than a lazy one (as in the first loop, where the window keeps it small); the factor
// is renewed (in float) when the lazy solves since the last factorisation have cost, beyond
// what the first of them cost (CG needs more iterations as the preconditioner ages, and the
// unfactored block grows), as much as renewing: a ski-rental rule, on flop estimates so
// that the same inputs give the same bits. A refactorisation after lazy updates takes its
// own update in lazily too (the positive-definiteness check through C), then brings S up
// to date in one pass over the features they all changed. If the float factorisation fails
// (S too ill-conditioned for it), the double one decides, and should that fail too, the
// lazy preconditioner stays (S passed the check through C).
//
// Memory is O(P^2) (S and L, 6P square, and L's float copy), so the filter uses it only up
// to a pose dimension. docs/filter_internals.md has the measurements behind the defaults.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "backend/lazy_pose_solver.h"
#include "backend/pose_schur_blocks.h"
#include "backend/windowed_pose_cholesky.h"

namespace ieslam {

struct PoseSchurOptions {
  // A pose outside the window is moved in with the poses within this many places of it in
  // the order poses were added.
  int prefetch = 12;
  // Poses not touched by this many updates leave the window.
  int evict_after = 8;
  // Lazy updates: conjugate gradients stop once sqrt(r^T M^-1 r), a bound on the error's
  // Mahalanobis norm sqrt(e^T S e) (so each component's error is below this many of its
  // standard deviations), is below cg_tolerance; past cg_max_iterations the factor is made
  // exact instead.
  double cg_tolerance = 1e-10;
  int cg_max_iterations = 60;
  // CG streams the factor and the couplings from memory, at a fraction of the flop rate of
  // the blocked factorisation: in the lazy-versus-exact cost comparisons its flops count
  // this many times (0: lazy whenever possible, for tests).
  double cg_flop_weight = 2.0;
  // The float factorisation's flop rate over the double one's, for the choice between
  // renewing the preconditioner in float and refactoring exactly (0: never in float).
  double single_speedup = 2.0;

  bool Check(std::string* why) const;
};

// How AddPose treats the factor.
enum class SchurUpdate {
  kDefer,  // accumulate S and the blocks only; Refactor() before any solve or query
  kExact,  // keep the factor exact
  kLazy,   // exact when that is cheaper, else leave the factor as a preconditioner
};

class PoseSchurFactor {
 public:
  // Throws ConfigError when the options fail Check.
  explicit PoseSchurFactor(const PoseSchurOptions& options = PoseSchurOptions());

  // Adds a pose at state offset `pose_offset` with its 6x6 block (observations plus any
  // prior) and its observations; new features come first in the state (their offsets must
  // be free). Returns false, leaving everything as before the call, when the updated matrix
  // is not positive definite (kDefer: not checked).
  bool AddPose(int pose_offset, const Eigen::Matrix<double, 6, 6>& I_pp,
               const std::vector<ObservationBlocks>& observations, SchurUpdate update);
  // Full factorisation (after deferred additions). False if not positive definite.
  bool Refactor();
  // Refactors what lazy updates left inexact (nothing if exact()). False, leaving the
  // preconditioner as it was, if S is numerically not positive definite. Needs valid().
  bool MakeExact();

  int num_poses() const { return blocks_.num_poses(); }
  // I^-1 i for the full state (the filter's offsets). Needs exact().
  Eigen::VectorXd Solve(const Eigen::VectorXd& info_vector) const;
  // The same from any valid factor: by substitution when exact, else by preconditioned
  // conjugate gradients from `guess` (a state vector; only its poses are read). False when
  // CG has not converged in options.cg_max_iterations (*x is then the last iterate).
  bool SolveIteratively(const Eigen::VectorXd& info_vector, const Eigen::VectorXd& guess,
                        Eigen::VectorXd* x);
  // Needs exact().
  double LogDet() const;
  // The rows and columns `indices` (state offsets) of I^-1. Needs exact().
  Eigen::MatrixXd InverseSubmatrix(const std::vector<int>& indices) const;
  // Nonzeros of the dense factor of S plus the features' blocks, for reports.
  int64_t FactorNonzeros() const;
  // The factor factors S, or (after lazy updates) S as it was for the poses then.
  bool valid() const { return factor_.valid(); }
  // L L^T = S, in double.
  bool exact() const { return factor_.exact(); }
  // CG iterations of the last SolveIteratively (0 when it substituted).
  int last_cg_iterations() const { return lazy_.last_iterations(); }

 private:
  // What a kLazy update does to the factor: nothing (lazy), refactor exactly, or renew the
  // float preconditioner.
  enum class Choice { kLazy, kExact, kRenew };
  // The cheapest for an update touching `touched` (the ski-rental rule).
  Choice ChooseUpdate(const std::vector<int>& touched) const;
  // Estimated flops of refactoring from position `first` (with the rank update forming the
  // trailing block from S unless `from_window`) for num_poses() + 1 poses.
  double RefactorFlops(int first, bool from_window) const;
  // After the blocks took the new pose in: the factor for it, as `update` and `choice` say.
  // False if the matrix is not positive definite.
  bool FactorAddition(SchurUpdate update, Choice choice, bool lazy, bool was_exact,
                      const PoseSchurBlocks::Change& change);
  // The factor's FactorFrom and RenewInSingle, with room made and the lazy costs reset.
  bool FactorFrom(const WindowedPoseCholesky::Plan& plan, const Eigen::MatrixXd* trailing);
  bool RenewInSingle(const WindowedPoseCholesky::Plan& plan);
  // Brings S up to date with the lazy updates' features and poses.
  void Sync();
  // Room for n scalar rows and columns in S and the factor (with room to spare).
  void Grow(int n);

  PoseSchurOptions options_;
  PoseSchurBlocks blocks_;
  WindowedPoseCholesky factor_;
  LazyPoseSolver lazy_;
};

}  // namespace ieslam
