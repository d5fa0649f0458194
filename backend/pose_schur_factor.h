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
// Memory is O(P^2) (S and L, 6P square), so the filter uses it only up to a pose dimension.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

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
};

class PoseSchurFactor {
 public:
  explicit PoseSchurFactor(const PoseSchurOptions& options = PoseSchurOptions());

  // Adds a pose at state offset `pose_offset` with its 6x6 block (observations plus any
  // prior) and its observations; new features come first in the state (their offsets must
  // be free). With `refactor` false only S and the blocks are accumulated (call Refactor()
  // before any query). Returns false, leaving everything as before the call, when the
  // updated matrix is not positive definite.
  bool AddPose(int pose_offset, const Eigen::Matrix<double, 6, 6>& I_pp,
               const std::vector<SchurObservation>& observations, bool refactor);
  // Full factorisation (after deferred additions). False if not positive definite.
  bool Refactor();

  int num_poses() const { return static_cast<int>(pose_offsets_.size()); }
  // I^-1 i for the full state (dimension `dim`, the filter's offsets).
  Eigen::VectorXd Solve(const Eigen::VectorXd& info_vector) const;
  double LogDet() const;
  // The rows and columns `indices` (state offsets) of I^-1.
  Eigen::MatrixXd InverseSubmatrix(const std::vector<int>& indices) const;
  // Nonzeros of the dense factor of S plus the features' blocks, for reports.
  int64_t FactorNonzeros() const;
  bool valid() const { return valid_; }

 private:
  struct Feature {
    int offset = 0;
    double log_det = 0.0;  // log det F
    Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d F_inv = Eigen::Matrix3d::Zero();
    std::vector<int> poses;                                  // pose indices
    std::vector<Eigen::Matrix<double, 6, 3>> couplings;      // I_pf per pose
  };
  int dim() const { return 6 * num_poses(); }
  // Refactors from position `first` on for the new `order` (pose per position) with the
  // window from `window_start`; positions before `first` keep their poses and columns of L.
  // `trailing`: the Schur complement of positions from `first` when known (C plus the
  // update); else it is formed from S and L's leading columns. Changes nothing on failure.
  bool FactorFrom(int first, const std::vector<int>& order, int window_start,
                  const Eigen::MatrixXd* trailing);
  void Grow(int n);

  PoseSchurOptions options_;
  std::vector<int> pose_offsets_;               // pose index -> state offset
  std::unordered_map<int, int> pose_of_offset_;
  std::vector<Feature> features_;
  std::unordered_map<int, int> feature_of_offset_;
  std::vector<int> last_touched_;               // pose index -> update count
  int updates_ = 0;
  Eigen::MatrixXd S_;      // pose index order, allocated with room to grow
  Eigen::MatrixXd L_;      // order_ (positions), lower triangle
  Eigen::MatrixXd C_;      // trailing Schur complement of the window (window positions)
  std::vector<int> order_;     // position (pose slot) -> pose index
  std::vector<int> position_;  // pose index -> position
  int window_start_ = 0;       // first window position (in poses)
  bool valid_ = false;
};

}  // namespace ieslam
