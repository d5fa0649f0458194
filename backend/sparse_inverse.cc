// Selected entries of A^-1 from SparseCholesky's factor: the marginal covariances of the
// EIF (pose covariances, the joint covariance of a look-ahead buffer's features).
//
// With L D L^T = P A P^T (D = I for an LL^T factor), (A^-1)_SS = Y^T D^-1 Y for
// Y = L^-1 P E_S, E_S the unit columns of the wanted variables. A unit column's forward
// solve is nonzero only on the elimination-tree path from its variable to the root, so on
// the simplicial factor the solves cover the union of those paths alone; the supernodal
// factor (one-shot factorisations) uses CHOLMOD's dense forward solve and drops the rows
// that stay zero.
#include <algorithm>
#include <cmath>
#include <vector>

#include <cholmod.h>
#include <glog/logging.h>
#include <Eigen/Core>

#include "backend/sparse_cholesky_impl.h"
#include "backend/sparse_information.h"

namespace ieslam {

namespace {

// Y^T Y for the rows of Y listed in `rows` (others are zero), exactly symmetric.
Eigen::MatrixXd GramOfRows(const Eigen::MatrixXd& Y_rows) {
  const int k = static_cast<int>(Y_rows.cols());
  Eigen::MatrixXd result = Eigen::MatrixXd::Zero(k, k);
  result.selfadjointView<Eigen::Lower>().rankUpdate(Y_rows.transpose());
  result.triangularView<Eigen::StrictlyUpper>() = result.transpose();
  return result;
}

}  // namespace

Eigen::MatrixXd SparseCholesky::InverseSubmatrix(const std::vector<int>& indices) const {
  CHECK(valid()) << "no valid factor";
  const int k = static_cast<int>(indices.size());
  for (const int index : indices) CHECK(index >= 0 && index < dim()) << index;
  if (k == 0) return Eigen::MatrixXd(0, 0);
  const cholmod_factor& L = *impl_->factor;
  const int n = static_cast<int>(L.n);
  const std::vector<int>& position = impl_->position;

  if (L.is_super) {
    CHECK(L.is_ll);
    Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(n, k);
    int first = n;
    for (int c = 0; c < k; ++c) {
      unit(position[indices[c]], c) = 1.0;
      first = std::min(first, position[indices[c]]);
    }
    cholmod_dense b = ViewAsCholmod(&unit);
    cholmod_dense* y = cholmod_solve(CHOLMOD_L, impl_->factor, &b, &impl_->common);
    CHECK(y != nullptr) << "CHOLMOD solve failed, status " << impl_->common.status;
    const Eigen::Map<const Eigen::MatrixXd> Y(static_cast<const double*>(y->x), n, k);
    std::vector<int> rows;  // rows above `first` are zero, and so are rows off the paths
    for (int i = first; i < n; ++i) {
      if (!(Y.row(i).array() == 0.0).all()) rows.push_back(i);
    }
    const Eigen::MatrixXd Y_rows = Y(rows, Eigen::all);
    cholmod_free_dense(&y, &impl_->common);
    return GramOfRows(Y_rows);
  }

  // Simplicial L D L^T, unit diagonal in L. The rows of Y that can be nonzero are the
  // wanted variables' paths to the root (parent = first row below the diagonal). The
  // columns are solved in chunks of kChunk, each over its own paths' union only, row by
  // row in factor order (row-major, so each step is a contiguous axpy over the chunk's
  // columns): a chunk's rows stay in cache, where all k columns at once would stream
  // megabytes per factor column, and nearby variables share most of their paths.
  constexpr int kChunk = 48;
  const int* Lp = static_cast<const int*>(L.p);
  const int* Li = static_cast<const int*>(L.i);
  const int* Lnz = static_cast<const int*>(L.nz);
  const double* Lx = static_cast<const double*>(L.x);
  const auto parent_of = [&](int j) {
    int parent = -1;
    for (int e = Lp[j] + 1; e < Lp[j] + Lnz[j]; ++e) {
      if (parent < 0 || Li[e] < parent) parent = Li[e];
    }
    return parent;
  };
  // Wanted columns sorted by factor position, so that a chunk holds nearby variables.
  std::vector<int> column_order(k);
  for (int c = 0; c < k; ++c) column_order[c] = c;
  std::sort(column_order.begin(), column_order.end(),
            [&](int a, int b) { return position[indices[a]] < position[indices[b]]; });
  std::vector<int> parent(n, -2);  // -2: not looked up yet
  std::vector<int> row_of(n, -1);  // factor row -> row of the chunk's compact Y
  std::vector<int> all_of(n, -1);  // factor row -> row of the whole compact Y
  std::vector<int> all_rows;
  std::vector<Eigen::MatrixXd> chunk_y;
  std::vector<std::vector<int>> chunk_rows;
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  for (int c0 = 0; c0 < k; c0 += kChunk) {
    const int width = std::min(kChunk, k - c0);
    std::vector<int> rows;
    for (int c = c0; c < c0 + width; ++c) {
      for (int j = position[indices[column_order[c]]]; j >= 0 && row_of[j] < 0;) {
        row_of[j] = 0;
        rows.push_back(j);
        if (parent[j] == -2) parent[j] = parent_of(j);
        j = parent[j];
      }
    }
    std::sort(rows.begin(), rows.end());
    for (size_t r = 0; r < rows.size(); ++r) row_of[rows[r]] = static_cast<int>(r);
    RowMajor Y = RowMajor::Zero(static_cast<int>(rows.size()), width);
    for (int c = 0; c < width; ++c) Y(row_of[position[indices[column_order[c0 + c]]]], c) = 1.0;
    for (size_t r = 0; r < rows.size(); ++r) {
      const int j = rows[r];
      for (int e = Lp[j] + 1; e < Lp[j] + Lnz[j]; ++e) {
        const int target = row_of[Li[e]];
        CHECK_GE(target, 0) << "row " << Li[e] << " of column " << j << " is off its path";
        Y.row(target) -= Lx[e] * Y.row(static_cast<Eigen::Index>(r));
      }
    }
    for (size_t r = 0; r < rows.size(); ++r) {
      Y.row(r) /= std::sqrt(Lx[Lp[rows[r]]]);  // D^-1/2
      row_of[rows[r]] = -1;
      if (all_of[rows[r]] < 0) {
        all_of[rows[r]] = 0;
        all_rows.push_back(rows[r]);
      }
    }
    chunk_y.emplace_back(Y);
    chunk_rows.push_back(std::move(rows));
  }
  // Scatter the chunks into one compact Y (rows in factor order, columns as asked).
  std::sort(all_rows.begin(), all_rows.end());
  for (size_t r = 0; r < all_rows.size(); ++r) all_of[all_rows[r]] = static_cast<int>(r);
  Eigen::MatrixXd Y_rows = Eigen::MatrixXd::Zero(static_cast<int>(all_rows.size()), k);
  for (size_t chunk = 0; chunk < chunk_y.size(); ++chunk) {
    const int c0 = static_cast<int>(chunk) * kChunk;
    for (size_t r = 0; r < chunk_rows[chunk].size(); ++r) {
      const int row = all_of[chunk_rows[chunk][r]];
      for (int c = 0; c < chunk_y[chunk].cols(); ++c) {
        Y_rows(row, column_order[c0 + c]) = chunk_y[chunk](static_cast<Eigen::Index>(r), c);
      }
    }
  }
  return GramOfRows(Y_rows);
}

}  // namespace ieslam
