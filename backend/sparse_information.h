// The information filter's matrix storage and its sparse Cholesky factor (CHOLMOD).
//
// UpperColumnStorage holds the upper triangle of a symmetric matrix in compressed columns
// and grows only by appending columns. That suits the EIF of Zhou et al. (2008): variables
// are only ever appended, and the filter places a new pose after its new features, so every
// coupling a new pose brings lands in the pose's own (new) columns. Existing columns change
// values (the diagonal blocks of re-observed features), never their pattern.
//
// SparseCholesky factors such a matrix with CHOLMOD's supernodal LL^T behind a fill-reducing
// ordering, and answers the questions the filter asks of the factor: solves, log det from
// the factor's diagonal, and selected entries of the inverse without forming all of it.
//
// Speed: the filter appends variables and adds information, so the factor is updated in
// place instead of refactored: after a full factorisation (fill-reducing ordering, then
// CHOLMOD's supernodal LL^T, converted to a simplicial LDL^T) the re-observed features'
// diagonal blocks are a low-rank update (cholmod_updown) and every new variable is a new
// row (cholmod_rowadd) in one of the identity slots kept spare at the end of the order. A
// fresh ordering and full factorisation happen only when the slots run out. On the
// paper's simulation this is 2-6x cheaper than refactoring per update; the pose block
// still fills in (every feature is seen from ~30 poses and the second loop re-observes the
// first), so the updates of a loop closure reach most of the factor.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace ieslam {

class UpperColumnStorage {
 public:
  int dim() const { return static_cast<int>(outer_.size()) - 1; }
  int64_t nonzeros() const { return static_cast<int64_t>(inner_.size()); }

  // Opens column dim(); entries are then appended to it with strictly ascending rows,
  // ending with the diagonal.
  void StartColumn() { outer_.push_back(outer_.back()); }
  void Append(int row, double value) {
    inner_.push_back(row);
    values_.push_back(value);
    ++outer_.back();
  }

  // Adds `block` to the dense diagonal block of columns [first, first + block.cols()),
  // which must be stored in full: the diagonal block is then the tail of each column.
  void AddToDiagonalBlock(int first, const Eigen::MatrixXd& block);
  // Copies the diagonal block out (to undo an update that failed).
  Eigen::MatrixXd DiagonalBlock(int first, int size) const;
  void SetDiagonalBlock(int first, const Eigen::MatrixXd& block);

  // Drops every column from `dim` on.
  void Truncate(int dim);

  Eigen::Map<const Eigen::SparseMatrix<double>> Upper() const;
  // Both triangles, for callers who want the matrix itself (sparsity plots, dense checks).
  Eigen::SparseMatrix<double> Full() const;

  const std::vector<int>& outer() const { return outer_; }
  const std::vector<int>& inner() const { return inner_; }
  const std::vector<double>& values() const { return values_; }

 private:
  std::vector<int> outer_{0};
  std::vector<int> inner_;
  std::vector<double> values_;
};

enum class FillReducingOrdering {
  kAmd,            // approximate minimum degree on the scalar pattern
  kCholmodChoice,  // CHOLMOD's default: AMD, and METIS too when AMD fills in badly
  kNatural,        // the order variables were added (for comparisons only)
  kMetis,          // nested dissection (METIS through CHOLMOD)
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

class SparseCholesky {
 public:
  // `spare_capacity`: identity slots kept for future variables, as a fraction of the
  // dimension at each full factorisation (0: none; Update() then always refuses).
  explicit SparseCholesky(FillReducingOrdering ordering, double spare_capacity = 0.0);
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Full factorisation: fill-reducing ordering, symbolic analysis and numeric factorisation
  // (`pattern_changed` is kept for the callers; the analysis is always redone). False if
  // the matrix is not positive definite; the previous factor is then kept, unchanged.
  bool Factorize(const UpperColumnStorage& matrix, bool pattern_changed);
  // In-place update to `matrix`, which must be the last factored matrix plus `increments`
  // on existing diagonal blocks and new columns [old_dim, matrix.dim()). False when there
  // is no room (no spare slots left, no incremental factor) or the result is not positive
  // definite; the factor is then invalid and the caller refactors.
  bool Update(const UpperColumnStorage& matrix, int old_dim,
              const std::vector<DiagonalIncrement>& increments);
  // Notes which variables an update touches (Update() does it too): while updates touch
  // mostly the recently added variables (exploring), the next full factorisation keeps
  // those last in the order they were added; when they touch older ones (closing a loop),
  // the fill-reducing ordering covers everything.
  void NoteUpdate(int old_dim, const std::vector<DiagonalIncrement>& increments);

  bool valid() const;
  int dim() const;
  // A^-1 B for the factored A.
  Eigen::MatrixXd Solve(const Eigen::MatrixXd& B) const;
  // log det A from the factor's diagonal.
  double LogDet() const;
  // The rows and columns `indices` of A^-1. With L D L^T = P A P^T, (A^-1)_SS =
  // Y^T D^-1 Y for Y = L^-1 P E_S: forward solves against the unit columns only, each
  // touching just the elimination-tree path above its variable, then a symmetric rank-k
  // product over the rows those paths cover.
  Eigen::MatrixXd InverseSubmatrix(const std::vector<int>& indices) const;
  // Nonzeros of the factor L (after fill-in), for reports.
  int64_t FactorNonzeros() const;

  const CholeskyTimings& timings() const { return timings_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  CholeskyTimings timings_;
};

}  // namespace ieslam
