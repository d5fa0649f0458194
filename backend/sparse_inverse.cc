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

#include <Eigen/Core>
#include <cholmod.h>
#include <glog/logging.h>

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
  // wanted variables' paths to the root (parent = first row below the diagonal); their
  // union U is solved for all columns at once, row by row in factor order (row-major Y, so
  // each step is a contiguous axpy over the k columns).
  const int* Lp = static_cast<const int*>(L.p);
  const int* Li = static_cast<const int*>(L.i);
  const int* Lnz = static_cast<const int*>(L.nz);
  const double* Lx = static_cast<const double*>(L.x);
  std::vector<int> row_of(n, -1);  // factor row -> row of the compact Y
  std::vector<int> rows;
  for (const int index : indices) {
    for (int j = position[index]; j >= 0 && row_of[j] < 0;) {
      row_of[j] = 0;
      rows.push_back(j);
      int parent = -1;
      for (int e = Lp[j] + 1; e < Lp[j] + Lnz[j]; ++e) {
        if (parent < 0 || Li[e] < parent) parent = Li[e];
      }
      j = parent;
    }
  }
  std::sort(rows.begin(), rows.end());
  for (size_t r = 0; r < rows.size(); ++r) row_of[rows[r]] = static_cast<int>(r);
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  RowMajor Y = RowMajor::Zero(static_cast<int>(rows.size()), k);
  for (int c = 0; c < k; ++c) Y(row_of[position[indices[c]]], c) = 1.0;
  for (size_t r = 0; r < rows.size(); ++r) {
    const int j = rows[r];
    for (int e = Lp[j] + 1; e < Lp[j] + Lnz[j]; ++e) {
      const int target = row_of[Li[e]];
      CHECK_GE(target, 0) << "row " << Li[e] << " of column " << j << " is off its path";
      Y.row(target) -= Lx[e] * Y.row(static_cast<Eigen::Index>(r));
    }
  }
  for (size_t r = 0; r < rows.size(); ++r) Y.row(r) /= std::sqrt(Lx[Lp[rows[r]]]);  // D^-1/2
  const Eigen::MatrixXd Y_rows = Y;
  return GramOfRows(Y_rows);
}

}  // namespace ieslam
