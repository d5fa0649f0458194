// The information matrix that PoseSchurFactor factors, held as its blocks, and its pose
// Schur complement S.
//
// A feature couples only with the poses that observe it (Zhou et al. 2008, §V-B: no motion
// model, no feature-feature terms), so the matrix is each pose's 6x6 block I_pp, each
// feature's 3x3 block F and the 6x3 couplings E between a feature and the poses that saw it.
// The features eliminate block by block:
//   S = I_pp - sum_f E_f^T F_f^-1 E_f
// is a dense 6P x 6P matrix, kept here in pose order (the 6x6 blocks on and below the
// diagonal only). Lazy additions leave S behind (the blocks stay exact): Sync() brings it up
// to date in one pass over the features they changed.
//
// Everything that reads the poses in a factor's order takes `position` (pose index -> its
// place in the factor); poses are numbered in the order added.
//
// A feature that enters the state on a later sighting (ObservationBlocks::earlier) couples
// with the earlier poses too, and adds to their blocks I_pp: for S that is the same kind of
// change as a re-observed feature's, on the earlier poses and the new one.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "backend/information_factor.h"

namespace ieslam {

class PoseSchurBlocks {
 private:
  // The fields of a feature that an observation changes; its lists only grow.
  struct FeatureValues {
    double log_det = 0.0;  // log det F
    Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d F_inv = Eigen::Matrix3d::Zero();
    // What S_ has taken in (lazy additions leave it behind): F, its inverse, the poses.
    Eigen::Matrix3d F_synced = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d F_inv_synced = Eigen::Matrix3d::Zero();
    int poses_synced = 0;
    bool unsynced = false;  // listed in unsynced_
  };

 public:
  using Matrix63 = Eigen::Matrix<double, 6, 3>;

  // What adding a pose does to S, worked out before anything changes.
  struct Change {
    std::vector<int> touched;  // poses that saw a re-observed feature, ascending
    std::vector<int> local;    // pose -> its place in `touched` (-1: untouched)
    // The change of S on the touched poses and the new pose's row (its last block),
    // symmetric; empty when S is not updated.
    Eigen::MatrixXd D;
    std::vector<Eigen::Matrix3d> new_inverse;  // per observation: the feature's F^-1 after
  };

  // What Revert needs to take the last AddPose back.
  class Undo {
   private:
    friend class PoseSchurBlocks;
    int pose_offset = 0;
    int old_features = 0;
    size_t old_unsynced = 0;
    int64_t observations = 0;
    std::vector<std::pair<int, FeatureValues>> saved;  // re-observed features as they were
    // Earlier poses' blocks I_pp as they were, and the length of unsynced_pose_increments_.
    std::vector<std::pair<int, Eigen::Matrix<double, 6, 6>>> saved_pose_blocks;
    size_t old_pose_increments = 0;
    bool earlier_couplings = false;  // couplings were inserted in earlier poses' runs
    bool updated_S = false;
    std::vector<int> scalar;  // S rows of the touched poses
    Eigen::MatrixXd S_saved;  // S on them before
  };

  int num_poses() const { return static_cast<int>(pose_offsets_.size()); }
  int dim() const { return 6 * num_poses(); }
  int num_features() const { return static_cast<int>(features_.size()); }
  int64_t num_couplings() const { return num_couplings_; }
  bool HasPoseAt(int offset) const { return pose_of_offset_.count(offset) > 0; }
  int pose_offset(int pose) const { return pose_offsets_[pose]; }
  // S in pose order, lower 6x6 blocks only, as far as Sync has brought it; rows and columns
  // past dim() are room to grow.
  const Eigen::MatrixXd& S() const { return S_; }
  int capacity() const { return static_cast<int>(S_.rows()); }
  // S keeps room for `capacity` scalar rows and columns (its contents are kept).
  void Reserve(int capacity);

  // The poses whose blocks of S adding `observations` changes.
  std::vector<int> TouchedPoses(const std::vector<ObservationBlocks>& observations) const;
  // The change a new pose with block I_pp and `observations` makes (D only if `of_S`).
  Change ComputeChange(const Eigen::Matrix<double, 6, 6>& I_pp,
                       const std::vector<ObservationBlocks>& observations, std::vector<int> touched,
                       bool of_S) const;
  // Adds the pose (state offset `pose_offset`; new features' offsets must be free) and its
  // observations to the blocks, and to S if `update_S` (which then must be synced and have
  // room for the new pose).
  Undo AddPose(int pose_offset, const Eigen::Matrix<double, 6, 6>& I_pp,
               const std::vector<ObservationBlocks>& observations, const Change& change,
               bool update_S);
  // Takes the last AddPose back, exactly.
  void Revert(const Undo& undo);
  // Brings S up to date with the blocks (it must have room for every pose).
  void Sync();

  // b = i_p - sum E^T F^-1 i_f, in factor positions: the pose system's right-hand side.
  Eigen::VectorXd ReducedRhs(const Eigen::VectorXd& info_vector,
                             const std::vector<int>& position) const;
  // The full state from the poses' solution x_p (features by back-substitution,
  // x_f = F^-1 (i_f - E_f x_p)), laid out at the state offsets.
  Eigen::VectorXd FullState(const Eigen::VectorXd& info_vector, const Eigen::VectorXd& x_p,
                            const std::vector<int>& position) const;
  // y = S x from the blocks (not from S, which may lag), in factor positions.
  void MultiplyS(const Eigen::VectorXd& x, const std::vector<int>& position,
                 Eigen::VectorXd* y) const;
  // S's blocks of the poses from `first_pose` on, from the blocks: C with them, and B
  // coupling them with the earlier poses (rows at their factor positions).
  void SchurBlocksOfPoses(int first_pose, const std::vector<int>& position, Eigen::MatrixXd* C,
                          Eigen::MatrixXd* B) const;
  // sum_f log det F_f, the features' share of log det I.
  double FeatureLogDet() const;

  // The state indices `indices` as right-hand sides of the pose system: the columns R with
  // I^-1 restricted to `indices` = R^T S^-1 R + the features' own F^-1 blocks.
  struct InverseColumns {
    Eigen::MatrixXd R;                            // dim() x indices.size(), factor positions
    std::vector<int> first_row;                   // per column: its first row that may be nonzero
    std::vector<std::pair<int, int>> feature_of;  // per column: (feature index or -1, component)
  };
  InverseColumns ColumnsOf(const std::vector<int>& indices, const std::vector<int>& position) const;
  // Adds the features' F^-1 entries to R^T S^-1 R (`inverse`), completing I^-1 there.
  void AddFeatureInverses(const InverseColumns& columns, Eigen::MatrixXd* inverse) const;

 private:
  struct Feature : FeatureValues {
    int offset = 0;
    std::vector<int> poses;           // pose indices, ascending
    std::vector<Matrix63> couplings;  // I_pf per pose
  };
  // Adds `obs` to its feature (a new one for a new feature); returns the feature's index.
  int AddObservation(const ObservationBlocks& obs, const Eigen::Matrix3d& new_inverse,
                     bool update_S, Undo* undo);
  // The new features' earlier sightings (`feature_order`: (feature index, observation) of
  // every observation): their increments of the earlier poses' blocks I_pp (noted for Sync
  // when S is not updated and has those poses already), and their couplings into the runs of
  // `pose_couplings_` of those poses.
  void AddEarlierSightings(const std::vector<ObservationBlocks>& observations,
                           const std::vector<std::pair<int, int>>& feature_order, bool update_S,
                           Undo* undo);
  // The change of S a new feature's earlier sightings make (D's blocks of the touched poses
  // and of the new pose, which is the last).
  void AddEarlierToChange(const ObservationBlocks& obs, const Eigen::Matrix3d& F_inv,
                          Change* change) const;
  // Rebuilds the pose-by-pose couplings without those of features from `first_feature` on in
  // the runs of the poses before `end_pose`.
  void DropCouplingsOfFeatures(int first_feature, int end_pose);
  // S += D on the touched poses, and the new pose's row and column.
  void AddToS(const Change& change, Undo* undo);

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
  // Pose index order, with room to grow; only the 6x6 blocks on and below the diagonal are
  // kept (Sync writes no others).
  Eigen::MatrixXd S_;
  // S_ holds the poses before synced_poses_, and every feature but those in unsynced_, and
  // every increment of the poses' blocks but those in unsynced_pose_increments_.
  int synced_poses_ = 0;
  std::vector<int> unsynced_;
  std::vector<std::pair<int, Eigen::Matrix<double, 6, 6>>> unsynced_pose_increments_;
};

}  // namespace ieslam
