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
};

// Seconds spent in the last calls, for the timing reports.
struct CholeskyTimings {
  double analyze_s = 0.0;
  double factorize_s = 0.0;
};

class SparseCholesky {
 public:
  explicit SparseCholesky(FillReducingOrdering ordering);
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Symbolic analysis (ordering, elimination tree, supernodes) when the pattern changed
  // since the last call, then the numeric factorisation. False if the matrix is not
  // positive definite; the previous factor is then gone (the caller refactors to undo).
  bool Factorize(const UpperColumnStorage& matrix, bool pattern_changed);

  bool valid() const;
  int dim() const;
  // A^-1 B for the factored A.
  Eigen::MatrixXd Solve(const Eigen::MatrixXd& B) const;
  // log det A = 2 sum log diag(L).
  double LogDet() const;
  // The rows and columns `indices` of A^-1, from solves against the matching unit columns
  // only (in chunks, so the memory is O(n * chunk), never O(n^2)).
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
