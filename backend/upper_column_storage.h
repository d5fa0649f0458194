// The information filter's matrix: the upper triangle of a symmetric matrix in compressed
// columns, grown only by appending columns.
//
// That suits the EIF of Zhou et al. (2008), §V-B: variables are only ever appended, and the
// filter places a new pose after its new features, so every coupling a new pose brings lands
// in the pose's own (new) columns. Existing columns change values (the diagonal blocks of
// re-observed features), never their pattern.
#pragma once

#include <cstdint>
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
  // Adds `value` to the stored entry (row, col), row <= col; CHECK-fails if the pattern
  // does not hold it.
  void AddToEntry(int row, int col, double value);
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

}  // namespace ieslam
