// A factorisation of the information filter's matrix I (Zhou et al. 2008, §V-B), behind the
// operations the filter needs of it: take in the update a new pose brings and recover the
// state I X = i (eq. 10), refactor after batch loading, log det I, entries of I^-1, and the
// factor's size and timings.
//
// Implementations: the sparse CHOLMOD factor (MakeSparseInformationFactor,
// backend/sparse_information_factor.h), the dense pose Schur complement
// (MakePoseSchurInformationFactor, backend/pose_schur_information_factor.h), and the
// filter's own DenseThenSparseFactor (backend/dense_then_sparse_factor.h): the dense one while
// the poses are few, then the sparse one.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace ieslam {

class UpperColumnStorage;

// An earlier sighting of a feature that enters the state with the pose being added (delayed
// initialisation, InformationFilterOptions::min_sightings): the observation made from a pose
// already in the state, which couples that pose with the new feature.
struct EarlierSightingBlocks {
  int pose_offset = 0;  // state offset of the earlier pose
  Eigen::Matrix<double, 6, 6> I_cc = Eigen::Matrix<double, 6, 6>::Zero();  // added to its block
  Eigen::Matrix<double, 6, 3> I_cf = Eigen::Matrix<double, 6, 3>::Zero();  // the coupling
};

// One observation of a feature from the pose being added: its blocks of the information
// matrix.
struct ObservationBlocks {
  int feature_offset = 0;                          // state offset of the feature
  bool is_new = false;                             // the feature enters with this pose
  Eigen::Matrix3d I_ff = Eigen::Matrix3d::Zero();  // added to the feature's block
  Eigen::Matrix<double, 6, 3> I_pf = Eigen::Matrix<double, 6, 3>::Zero();  // the coupling
  // A new feature's sightings from earlier poses, in the order of their offsets (I_ff then
  // holds theirs too); empty for a feature that enters at its first sighting.
  std::vector<EarlierSightingBlocks> earlier;
};

// What a new pose does to I besides appending its columns: the new features' columns come
// first, from old_dim on, then the pose's six. Existing columns change only on diagonal
// blocks: the re-observed features', and the earlier poses' of features that enter on a later
// sighting (their couplings with those poses lie in the new features' columns).
struct InformationUpdate {
  int old_dim = 0;  // I's dimension before the update
  // The pose's diagonal block (its observations and any prior).
  Eigen::Matrix<double, 6, 6> pose_block = Eigen::Matrix<double, 6, 6>::Zero();
  // Every observation the pose brings.
  std::vector<ObservationBlocks> observations;
};

// Seconds spent in the last update or refactorisation.
struct FactorTimings {
  double analyze_s = 0.0;    // ordering and symbolic analysis (full sparse factorisations)
  double factorize_s = 0.0;  // factorisation, or the update of the factor
  double solve_s = 0.0;      // recovery of the state
  int cg_iterations = 0;     // of a recovery by conjugate gradients (0: by substitution)
};

enum class FactorStatus {
  kOk,
  // Refused, the updated matrix not being positive definite: the factor is as before the
  // call, for the matrix without the update (see Restore).
  kNotPositiveDefinite,
  // Taken in, but the factor cannot recover the state (numerically): it is of no further
  // use, and another factorisation has to take the matrix over.
  kUnsolved,
};

class InformationFactor {
 public:
  virtual ~InformationFactor() = default;

  // Takes in `update` (`matrix` is now the matrix taken in so far plus the update) and
  // recovers the state into *state: exactly when `keep_exact`, else by conjugate gradients
  // from `guess` where the factor can (the previous state with the new pose's initial
  // value; only its poses are read), which may leave the factor a preconditioner.
  virtual FactorStatus AddAndSolve(const UpperColumnStorage& matrix,
                                   const InformationUpdate& update, bool keep_exact,
                                   const Eigen::VectorXd& info_vector, const Eigen::VectorXd& guess,
                                   Eigen::VectorXd* state) = 0;
  // Batch loading: takes in `update` without factoring. Refactor() must come before any
  // solve or query.
  virtual void AddDeferred(const UpperColumnStorage& matrix, const InformationUpdate& update) = 0;
  // After a refused update: `matrix` is the matrix before it again. `factored`: that matrix
  // had been factored (no deferred update pending), and the factor is made one of it again
  // if the refusal dropped it.
  virtual void Restore(const UpperColumnStorage& matrix, bool factored) = 0;
  // A full factorisation of `matrix` (after deferred updates). False if it is not positive
  // definite.
  virtual bool Refactor(const UpperColumnStorage& matrix) = 0;

  // The queries below need an exact factor: MakeExact() first (after an iterative
  // recovery); it CHECK-fails if the matrix is numerically not positive definite.
  virtual void MakeExact() = 0;
  // I^-1 i for the full state.
  virtual Eigen::VectorXd Solve(const Eigen::VectorXd& info_vector) const = 0;
  virtual double LogDet() const = 0;
  // The rows and columns `indices` (state offsets) of I^-1.
  virtual Eigen::MatrixXd InverseSubmatrix(const std::vector<int>& indices) const = 0;
  // Nonzeros of the factor, for reports.
  virtual int64_t FactorNonzeros() const = 0;

  virtual const FactorTimings& timings() const = 0;
  // True while the dense pose Schur complement factors the matrix.
  virtual bool uses_pose_schur() const = 0;
};

// The part of an InformationFactor that a wrapped exact factor of the matrix answers as it
// stands (SparseCholesky, PoseSchurFactor: their Solve, LogDet, InverseSubmatrix and
// FactorNonzeros), and the timings; an implementation adds the updates.
template <typename Factor>
class WrappedInformationFactor : public InformationFactor {
 public:
  Eigen::VectorXd Solve(const Eigen::VectorXd& info_vector) const override {
    return factor_.Solve(info_vector);
  }
  double LogDet() const override { return factor_.LogDet(); }
  Eigen::MatrixXd InverseSubmatrix(const std::vector<int>& indices) const override {
    return factor_.InverseSubmatrix(indices);
  }
  int64_t FactorNonzeros() const override { return factor_.FactorNonzeros(); }
  const FactorTimings& timings() const override { return timings_; }

 protected:
  template <typename Options>
  explicit WrappedInformationFactor(const Options& options) : factor_(options) {}

  Factor factor_;
  FactorTimings timings_;
};

}  // namespace ieslam
