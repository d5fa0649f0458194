// The EIF's information matrix factored through its pose Schur complement: an exact
// alternative to SparseCholesky for problems with few poses and a dense pose block.
//
// A feature couples only with the poses that observe it (no motion model, no feature-feature
// terms), so its 3x3 diagonal block F_f can be eliminated on its own:
//   S = I_pp - sum_f E_f^T F_f^-1 E_f        (E_f: the feature's 3 x 6P coupling rows)
// is the pose Schur complement, and I X = i is solved by S x_p = i_p - sum E^T F^-1 i_f, then
// x_f = F^-1 (i_f - E_f x_p); log det I = sum log det F_f + log det S.
//
// Why: when a trajectory comes back (the paper's second loop) S fills in completely, and each
// update re-observes ~100 features seen from poses of both loops, a rank-~300 change of S.
// A sparse factor pays that change along paths through the whole pose block (hundreds of
// Mflops per update, at CHOLMOD's row-by-row speed). Here S is dense, ordered so that the
// poses the updates touch form a trailing window W: S's factor is L = [L_ll 0; L_wl L_ww] and
// C = S_ww - L_wl L_wl^T is kept, so an update that touches only W adds its change to C and
// refactors C alone (|W|^3 / 3 flops, dense blocked). A touched pose outside W is moved in
// together with its neighbours in time (the trajectory will likely revisit them next), and
// the factor is recomputed from the first moved position; poses untouched for a while leave
// W at its front, which costs nothing extra.
//
// Lazy updates (SchurUpdate::kLazy). Even so, an update of the paper's second loop touches
// poses of the first loop and refactors most of S: O(P^3), ~0.2 s at 300 poses. But an update
// only needs I X = i solved; log det and covariances are asked for far less often. So a lazy
// update keeps the features' blocks exact and leaves S_ and L as they were (S_ catches up
// before the next factorisation, each changed feature once): the poses added since (N, few)
// are eliminated exactly and L stands in for the rest,
//   M = [M_old + B C^-1 B^T, B; B^T, C]   (C = S_NN, B = S_old,N, M_old = L L^T),
// the preconditioner of conjugate gradients on S x_p = b (SolveIteratively), warm-started
// from the previous estimate. S - M = [S/C - M_old, 0; 0, 0], and S/C, the information on
// the old poses with everything else marginalised, only grows as observations come, so
// M <= S: CG's error has a computable bound, and S is positive definite exactly when C is
// (the check an update needs). The factor is made exact (MakeExact, refactoring from the
// first old pose the lazy updates touched) when a query needs it, or when CG does not
// converge. An update is made exactly when that costs less than a lazy one (as in the first
// loop, where the window keeps it small); the factor is renewed (in float, below) when the
// lazy solves since the last factorisation have cost, beyond what the first of them cost
// (CG needs more iterations as M ages, and N grows), as much as renewing: a ski-rental
// rule, on flop estimates so that the same inputs give the same bits. A refactorisation
// after lazy updates takes its own update in lazily too (the check through C), then brings
// S_ up to date in one pass over the features they all changed. Measured on the
// paper's simulation at 300 poses: CG takes 5-7 iterations right after a factorisation,
// ~10 thirty updates later.
//
// Single-precision preconditioner. CG's triangular solves stream L from memory, and the
// refactoring that the ski-rental rule calls for only renews the preconditioner: both are
// done on a float copy of L (half the bytes, and twice the SIMD lanes in the blocked
// factorisation), while the residuals, S x and the iterates stay double, so CG still
// converges to cg_tolerance; the error bound above then holds up to the float factor's
// relative error (the tests check the solves against the dense one to 1e-9). Such a renewal
// leaves the double factor exact only in the leading columns it did not touch: MakeExact
// refactors the rest in double, and an exact update after a renewal costs accordingly
// (which the choice counts). If the float factorisation fails (S too ill-conditioned for
// it), the double one decides (and should that fail too, the lazy preconditioner stays: S
// passed the check through C). Measured at 300 poses (the 7,275-dimensional benchmark):
// 34-41 ms per update on average instead of 53-55, side by side on a noisy shared machine.
//
// Where the time goes now (timers on the same benchmark, 24 updates; the shares are at
// cg_tolerance 1e-10, ~7.1 CG iterations an update; at 1e-6, ~4.5, and the solves take
// ~7-8 ms of an update against ~11, the renewals ~9.5 ms against ~8; at the filter's
// default of 1e-3, ~2.8): ~60% in CG, each iteration ~0.6-0.9 ms for S x (two passes over
// ~30,000 couplings, which are also kept pose by pose so that the passes stream them from
// one array) and ~0.5 ms for the two float triangular solves, bound by memory; ~27%
// in a renewal every ~12 updates (~62 ms to factor in float, ~8-14 ms for Sync, which
// writes S's lower blocks a pose's columns at a time). That is 0.62-0.76 of the mean
// update time before these changes (couplings read feature by feature, S mirrored, a
// renewal's own change of S formed apart, cg_flop_weight 5 and renewals every ~7
// updates), side by side. Not used: a tiled factorisation on two threads (same bits for
// any count), 1.5x faster alone on the 2-vCPU machine when quiet, but no faster in the
// benchmark while others shared it, and up to 1.5x slower under heavy load; a second copy
// of the couplings, feature by feature in one array, so that S x reads each once: only
// ~8% faster S x (the small block products bound it as much as memory).
//
// Memory is O(P^2) (S and L, 6P square, and L's float copy), so the filter uses it only up
// to a pose dimension.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace ieslam {

// One observation of a feature from the pose being added, in information form.
struct SchurObservation {
  int feature_offset = 0;                          // state offset of the feature
  bool is_new = false;                             // the feature enters with this pose
  Eigen::Matrix3d I_ff = Eigen::Matrix3d::Zero();  // added to the feature's block
  Eigen::Matrix<double, 6, 3> I_pf = Eigen::Matrix<double, 6, 3>::Zero();
};

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
  // this many times. Measured on the paper's simulation at 300 poses: a CG iteration (~5.6
  // Mflop as CgIterationFlops counts) takes ~1.1-1.4 ms, a renewal (~0.49 Gflop as counted)
  // ~72 ms with its Sync, so ~1.3-1.6; of 1.5, 2, 3 and 5 (the weight when CG read the
  // couplings feature by feature), 2 and 1.5 renew every 12-14 updates instead of 7 and
  // spend ~15 ms per update on CG and renewals together instead of ~18 (counted iterations
  // and renewals priced at those times), and 2 ran the all-frames simulation in 0.9 of the
  // time of 5. (0: lazy whenever possible, for tests.)
  double cg_flop_weight = 2.0;
  // The float factorisation's flop rate over the double one's, for the choice between
  // renewing the preconditioner in float and refactoring exactly (0: never in float).
  // SSE2 holds 4 floats or 2 doubles; measured on the paper's simulation at 300 poses, a
  // renewal takes ~1/1.5 of a double refactorisation (gathering S and the rank update
  // included), yet 2 gave the lower mean update time (34-41 ms vs 36-38, side by side).
  double single_speedup = 2.0;
};

// How AddPose treats the factor.
enum class SchurUpdate {
  kDefer,  // accumulate S and the blocks only; Refactor() before any solve or query
  kExact,  // keep the factor exact
  kLazy,   // exact when that is cheaper, else leave the factor as a preconditioner
};

class PoseSchurFactor {
 public:
  using Matrix63 = Eigen::Matrix<double, 6, 3>;

  explicit PoseSchurFactor(const PoseSchurOptions& options = PoseSchurOptions());

  // Adds a pose at state offset `pose_offset` with its 6x6 block (observations plus any
  // prior) and its observations; new features come first in the state (their offsets must
  // be free). Returns false, leaving everything as before the call, when the updated matrix
  // is not positive definite (kDefer: not checked).
  bool AddPose(int pose_offset, const Eigen::Matrix<double, 6, 6>& I_pp,
               const std::vector<SchurObservation>& observations, SchurUpdate update);
  // Full factorisation (after deferred additions). False if not positive definite.
  bool Refactor();
  // Refactors what lazy updates left inexact (nothing if exact()). False, leaving the
  // preconditioner as it was, if S is numerically not positive definite. Needs valid().
  bool MakeExact();

  int num_poses() const { return static_cast<int>(pose_offsets_.size()); }
  // I^-1 i for the full state (dimension `dim`, the filter's offsets). Needs exact().
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
  // L factors S, or (after lazy updates) S as it was for the poses then.
  bool valid() const { return valid_; }
  // L L^T = S, in double.
  bool exact() const {
    return valid_ && static_cast<int>(order_.size()) == num_poses() &&
           double_columns_ == static_cast<int>(order_.size());
  }
  // CG iterations of the last SolveIteratively (0 when it substituted).
  int last_cg_iterations() const { return last_cg_iterations_; }

 private:
  struct Feature {
    int offset = 0;
    double log_det = 0.0;  // log det F
    Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d F_inv = Eigen::Matrix3d::Zero();
    // What S_ has taken in (lazy updates leave it behind): F, its inverse, the poses.
    Eigen::Matrix3d F_synced = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d F_inv_synced = Eigen::Matrix3d::Zero();
    int poses_synced = 0;
    bool unsynced = false;            // listed in unsynced_
    std::vector<int> poses;           // pose indices
    std::vector<Matrix63> couplings;  // I_pf per pose
  };
  // A new order of the factor's positions: from `first` on it changes.
  struct Plan {
    int first = 0;
    std::vector<int> order;  // position -> pose index
    int window_start = 0;
  };
  int dim() const { return 6 * num_poses(); }
  // Moves the `touched` poses outside the window into it (with their neighbours in time),
  // evicts the poses untouched for a while, and appends the poses not yet factored.
  Plan PlanWindow(const std::vector<int>& touched) const;
  // The exact trailing block for `plan` when it moves nothing in: C plus the update `D` of
  // the pose just added (D's rows: `local` of the touched poses, then the new pose).
  Eigen::MatrixXd UpdatedWindow(const Plan& plan, const std::vector<int>& local,
                                const Eigen::MatrixXd& D) const;
  // What a kLazy update does to the factor: nothing (lazy), refactor exactly, or renew the
  // float preconditioner.
  enum class Choice { kLazy, kExact, kRenew };
  // The cheapest for an update touching `touched` (the ski-rental rule).
  Choice ChooseUpdate(const std::vector<int>& touched) const;
  // Estimated flops of refactoring from position `first` (with the rank update forming the
  // trailing block from S unless `from_window`) for k + 1 poses.
  double RefactorFlops(int first, bool from_window) const;
  // Estimated flops of preparing the preconditioner for `lazy_n` unfactored dimensions.
  double LazyPreparationFlops(double lazy_n) const;
  // Brings S_ up to date with the lazy updates' features and poses.
  void Sync();
  // The preconditioner after a lazy update: C (S's block of the poses not in L) factored
  // and B (their coupling with the factored poses) gathered. False if C is not positive
  // definite, that is (M_old being so) if S is not.
  bool PrepareLazyPreconditioner();
  // Factored poses touched by an update since the last exact factorisation.
  std::vector<int> DirtyPoses() const;
  // Refactors from position `first` on for the new `order` (pose per position) with the
  // window from `window_start`; positions before `first` keep their poses and columns of L.
  // `trailing`: the Schur complement of positions from `first` when known (C plus the
  // update); else it is formed from S and L's leading columns. Changes nothing on failure.
  bool FactorFrom(int first, const std::vector<int>& order, int window_start,
                  const Eigen::MatrixXd* trailing);
  // The same in float, into the float copy only: a preconditioner (no C, no exact factor);
  // the double factor keeps its leading columns (rows moved). False if the float
  // factorisation fails; then nothing changes.
  bool RenewInSingle(int first, const std::vector<int>& order, int window_start);
  // The new order and window after a factorisation.
  void Commit(const std::vector<int>& order, int window_start);
  // Brings the float copy's rows up to date with the double factor.
  void SyncSingle();
  void Grow(int n);
  // The pose system's right-hand side b = i_p - sum E^T F^-1 i_f, in factor positions,
  // and the full state from its solution x_p (features by back-substitution).
  Eigen::VectorXd ReducedRhs(const Eigen::VectorXd& info_vector) const;
  Eigen::VectorXd FullState(const Eigen::VectorXd& info_vector, const Eigen::VectorXd& x_p) const;
  // y = S x from the blocks (S = I_pp - sum E^T F^-1 E), in factor positions.
  void MultiplyS(const Eigen::VectorXd& x, Eigen::VectorXd* y) const;
  // z = M^-1 z (M = S when exact), with the double factor or its float copy.
  void ApplyPreconditioner(bool single, Eigen::VectorXd* z) const;
  // Flops of one CG iteration: the two triangular solves and the product with S.
  double CgIterationFlops() const;

  PoseSchurOptions options_;
  std::vector<int> pose_offsets_;                         // pose index -> state offset
  std::vector<Eigen::Matrix<double, 6, 6>> pose_blocks_;  // pose index -> its I_pp
  std::unordered_map<int, int> pose_of_offset_;
  std::vector<Feature> features_;
  std::unordered_map<int, int> feature_of_offset_;
  int64_t num_couplings_ = 0;  // pose-feature blocks in all
  // The couplings again, pose by pose (pose index order, each pose's in feature order, so
  // that sums over them run in the same order as feature by feature): the passes over all
  // of them (CG's products with S, the right-hand side, the features' recovery) stream
  // them from one array instead of hopping between the features' own.
  std::vector<Matrix63, Eigen::aligned_allocator<Matrix63>> pose_couplings_;
  std::vector<int> pose_coupling_features_;  // feature index of each
  std::vector<int> pose_coupling_ends_;      // pose index -> end of its couplings
  std::vector<int> last_touched_;            // pose index -> update count
  int updates_ = 0;
  // Pose index order, with room to grow; only the 6x6 blocks on and below the diagonal are
  // kept (Sync writes no others).
  Eigen::MatrixXd S_;
  Eigen::MatrixXd L_;          // order_ (positions), lower triangle
  Eigen::MatrixXd C_;          // trailing Schur complement of the window (window positions)
  Eigen::MatrixXf L_single_;   // float L: CG's preconditioner (allocated on first use)
  int double_columns_ = 0;     // L_'s leading columns (in poses) that are exact
  int single_rows_ = 0;        // L_single_'s leading rows (in poses) that are up to date
  std::vector<int> order_;     // position (pose slot) -> pose index
  std::vector<int> position_;  // pose index -> position
  int window_start_ = 0;       // first window position (in poses)
  bool valid_ = false;
  // Lazy updates: the poses added since the last exact factorisation (indices from
  // order_.size() on, positions equal to their indices) are not in L; C = S's block of them,
  // factored, and B = S's block coupling them with the factored poses (in positions).
  Eigen::LLT<Eigen::MatrixXd> lazy_llt_;
  Eigen::MatrixXd lazy_B_;
  int exact_since_update_ = 0;  // updates_ at the last exact factorisation
  // S_ holds the poses before synced_poses_, and every feature but those in unsynced_.
  int synced_poses_ = 0;
  std::vector<int> unsynced_;
  // Estimated cost of the lazy updates since then, beyond the cost of the first one.
  double lazy_flops_ = 0.0;
  int baseline_iterations_ = -1;  // CG iterations of the first lazy solve since then
  int last_cg_iterations_ = 0;
};

}  // namespace ieslam
