#include "backend/upper_column_storage.h"

#include <algorithm>

#include <glog/logging.h>

namespace ieslam {

void UpperColumnStorage::AddToDiagonalBlock(int first, const Eigen::MatrixXd& block) {
  CHECK_EQ(block.rows(), block.cols());
  CHECK_LE(first + block.cols(), dim());
  for (int k = 0; k < block.cols(); ++k) {
    const int end = outer_[first + k + 1];
    const int begin = end - (k + 1);
    CHECK_GE(begin, outer_[first + k]) << "diagonal block of column " << first + k << " not dense";
    DCHECK_EQ(inner_[begin], first);
    for (int r = 0; r <= k; ++r) values_[begin + r] += block(r, k);
  }
}

void UpperColumnStorage::AddToEntry(int row, int col, double value) {
  CHECK_LE(row, col);
  CHECK_LT(col, dim());
  const auto begin = inner_.begin() + outer_[col], end = inner_.begin() + outer_[col + 1];
  const auto it = std::lower_bound(begin, end, row);
  CHECK(it != end && *it == row) << "entry (" << row << ", " << col << ") is not stored";
  values_[it - inner_.begin()] += value;
}

Eigen::MatrixXd UpperColumnStorage::DiagonalBlock(int first, int size) const {
  Eigen::MatrixXd block = Eigen::MatrixXd::Zero(size, size);
  for (int k = 0; k < size; ++k) {
    const int begin = outer_[first + k + 1] - (k + 1);
    for (int r = 0; r <= k; ++r) block(r, k) = block(k, r) = values_[begin + r];
  }
  return block;
}

void UpperColumnStorage::SetDiagonalBlock(int first, const Eigen::MatrixXd& block) {
  for (int k = 0; k < block.cols(); ++k) {
    const int begin = outer_[first + k + 1] - (k + 1);
    for (int r = 0; r <= k; ++r) values_[begin + r] = block(r, k);
  }
}

void UpperColumnStorage::Truncate(int dim) {
  CHECK_LE(dim, this->dim());
  outer_.resize(dim + 1);
  inner_.resize(outer_.back());
  values_.resize(outer_.back());
}

Eigen::Map<const Eigen::SparseMatrix<double>> UpperColumnStorage::Upper() const {
  return Eigen::Map<const Eigen::SparseMatrix<double>>(dim(), dim(), nonzeros(), outer_.data(),
                                                       inner_.data(), values_.data());
}

Eigen::SparseMatrix<double> UpperColumnStorage::Full() const {
  return Eigen::SparseMatrix<double>(Upper().selfadjointView<Eigen::Upper>());
}

}  // namespace ieslam
