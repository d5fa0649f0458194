// A sparse Cholesky factor (CHOLMOD) of the information filter's matrix, and the questions
// the filter asks of it: solves, log det from the factor's diagonal, and selected entries of
// the inverse without forming all of it.
//
// The filter appends variables and adds information, so the factor is updated in place
// rather than refactored: after a full factorisation (a fill-reducing ordering, then
// CHOLMOD's supernodal LL^T, converted to a simplicial LDL^T) the re-observed features'
// diagonal blocks are a low-rank update (cholmod_updown) and every new variable is a new row
// (cholmod_rowadd) in one of the identity slots kept spare at the end of the order. A fresh
// ordering and full factorisation happen only when the slots run out. The pose block still
// fills in when the trajectory comes back, so the updates of a loop closure reach most of
// the factor (docs/filter_internals.md has the measurements).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "backend/upper_column_storage.h"

namespace ieslam {

enum class FillReducingOrdering {
  kAmd,            // approximate minimum degree on the scalar pattern
  kCholmodChoice,  // CHOLMOD's default: AMD, and METIS too when AMD fills in badly
  kNatural,        // the order variables were added (for comparisons only)
  kMetis,          // nested dissection (METIS through CHOLMOD)
};

struct SparseCholeskyOptions {
  FillReducingOrdering ordering = FillReducingOrdering::kMetis;
  // Identity slots kept for future variables, as a fraction of the dimension at each full
  // factorisation (0: none; Update() then always refuses).
  double spare_capacity = 0.0;

  bool Check(std::string* why) const;
};

// Seconds spent in the last calls, for the timing reports.
struct CholeskyTimings {
  double analyze_s = 0.0;
  double factorize_s = 0.0;
  bool reordered = false;  // the last analysis computed a fresh fill-reducing ordering
};

// A positive semidefinite 3x3 addition to the diagonal block of variables
// [first, first + 3).
struct DiagonalIncrement {
  int first = 0;
  Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
};

// A positive semidefinite 6x6 addition to the diagonal block of variables [first, first + 6):
// a pose's, from the earlier sightings of features that enter the state on a later one.
struct PoseIncrement {
  int first = 0;
  Eigen::Matrix<double, 6, 6> block = Eigen::Matrix<double, 6, 6>::Zero();
};

class SparseCholesky {
 public:
  // Throws ConfigError when the options fail Check. Not copyable: it owns the CHOLMOD state.
  explicit SparseCholesky(const SparseCholeskyOptions& options);
  ~SparseCholesky();

  // Full factorisation: fill-reducing ordering, symbolic analysis and numeric factorisation
  // (`pattern_changed` is kept for the callers; the analysis is always redone). False if
  // the matrix is not positive definite; the previous factor is then kept, unchanged.
  bool Factorize(const UpperColumnStorage& matrix, bool pattern_changed);
  // In-place update to `matrix`, which must be the last factored matrix plus `increments`
  // and `pose_increments` on existing diagonal blocks and new columns [old_dim, matrix.dim())
  // (which may couple with any earlier variable). False when there is no room (no spare
  // slots left, no incremental factor) or the result is not positive definite; the factor is
  // then invalid and the caller refactors.
  bool Update(const UpperColumnStorage& matrix, int old_dim,
              const std::vector<DiagonalIncrement>& increments,
              const std::vector<PoseIncrement>& pose_increments = {});
  // Notes which variables an update touches (Update() does it too): while updates touch
  // mostly the recently added variables (exploring), the next full factorisation keeps
  // those last in the order they were added; when they touch older ones (closing a loop),
  // the fill-reducing ordering covers everything.
  void NoteUpdate(int old_dim, const std::vector<DiagonalIncrement>& increments,
                  const std::vector<PoseIncrement>& pose_increments = {});

  bool valid() const;
  int dim() const;
  // A^-1 B for the factored A.
  Eigen::MatrixXd Solve(const Eigen::MatrixXd& B) const;
  // log det A from the factor's diagonal.
  double LogDet() const;
  // The rows and columns `indices` of A^-1. With L D L^T = P A P^T (D = I for an LL^T
  // factor), (A^-1)_SS = Y^T D^-1 Y for Y = L^-1 P E_S, E_S the unit columns of the wanted
  // variables. A unit column's forward solve is nonzero only on the elimination-tree path
  // from its variable to the root, so on the simplicial factor the solves cover the union of
  // those paths alone; the supernodal factor (one-shot factorisations) uses CHOLMOD's dense
  // forward solve and drops the rows that stay zero.
  Eigen::MatrixXd InverseSubmatrix(const std::vector<int>& indices) const;
  // Nonzeros of the factor L (after fill-in), for reports.
  int64_t FactorNonzeros() const;

  const CholeskyTimings& timings() const { return timings_; }

 private:
  struct Impl;  // the CHOLMOD state
  std::unique_ptr<Impl> impl_;
  CholeskyTimings timings_;
};

}  // namespace ieslam
