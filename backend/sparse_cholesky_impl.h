// SparseCholesky's CHOLMOD state, shared by its translation units (sparse_information.cc:
// factorisation and updates; sparse_inverse.cc: entries of the inverse). Private to backend/.
#pragma once

#include <algorithm>
#include <memory>
#include <vector>

#include <cholmod.h>
#include <glog/logging.h>
#include <Eigen/Core>

#include "backend/sparse_information.h"

namespace ieslam {

// A CHOLMOD view of the storage (no copy); CHOLMOD reads it only.
// `dim` < matrix.dim() views the leading principal submatrix.
inline cholmod_sparse ViewAsCholmod(const UpperColumnStorage& matrix, int dim = -1) {
  if (dim < 0) dim = matrix.dim();
  cholmod_sparse A{};
  A.nrow = A.ncol = static_cast<size_t>(dim);
  A.nzmax = static_cast<size_t>(matrix.outer()[dim]);
  A.p = const_cast<int*>(matrix.outer().data());
  A.i = const_cast<int*>(matrix.inner().data());
  A.x = const_cast<double*>(matrix.values().data());
  A.stype = 1;  // upper triangle of a symmetric matrix
  A.itype = CHOLMOD_INT;
  A.xtype = CHOLMOD_REAL;
  A.dtype = CHOLMOD_DOUBLE;
  A.sorted = 1;
  A.packed = 1;
  return A;
}

inline cholmod_dense ViewAsCholmod(Eigen::MatrixXd* B) {
  cholmod_dense view{};
  view.nrow = static_cast<size_t>(B->rows());
  view.ncol = static_cast<size_t>(B->cols());
  view.nzmax = view.nrow * view.ncol;
  view.d = view.nrow;
  view.x = B->data();
  view.xtype = CHOLMOD_REAL;
  view.dtype = CHOLMOD_DOUBLE;
  return view;
}

// The share of the variables, the most recently added, kept out of the fill-reducing
// ordering and placed last in the order they were added, while the updates explore:
// at least kExploringShare of the re-observed blocks lie among the kExploringWindow most
// recent variables (closing a loop re-observes older ones); see Factorize().
constexpr double kRecentFraction = 0.03;
constexpr double kExploringWindow = 0.2;
constexpr double kExploringShare = 0.9;

struct SparseCholesky::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  bool numeric_ok = false;
  FillReducingOrdering ordering;
  double spare_capacity = 0.0;
  int used = 0;               // variables in use; the factor's others are identity slots
  std::vector<int> position;  // variable -> its row in the factor (the inverse of Perm)
  // Share of the re-observed blocks among the kExploringWindow most recent variables, in
  // the last update (1 before any).
  double touched_recent = 1.0;

  Impl(FillReducingOrdering method, double spare) : ordering(method), spare_capacity(spare) {
    cholmod_start(&common);
    common.print = 0;  // failures are reported through return values, not stdout
    common.supernodal = CHOLMOD_SUPERNODAL;
    common.final_asis = 1;
  }
  ~Impl() {
    FreeFactor();
    cholmod_finish(&common);
  }
  void FreeFactor() {
    if (factor != nullptr) cholmod_free_factor(&factor, &common);
    numeric_ok = false;
  }

  // A fill-reducing ordering of A (its Perm array).
  std::vector<int> Ordering(cholmod_sparse* A) {
    const int n = static_cast<int>(A->nrow);
    std::vector<int> perm(n);
    int ok = 1;
    switch (ordering) {
      case FillReducingOrdering::kNatural:
        for (int i = 0; i < n; ++i) perm[i] = i;
        break;
      case FillReducingOrdering::kAmd:
        ok = cholmod_amd(A, nullptr, 0, perm.data(), &common);
        break;
      case FillReducingOrdering::kMetis:
        ok = cholmod_metis(A, nullptr, 0, /*postorder=*/1, perm.data(), &common);
        break;
      case FillReducingOrdering::kCholmodChoice: {
        common.nmethods = 0;
        cholmod_factor* symbolic = cholmod_analyze(A, &common);
        ok = symbolic != nullptr;
        if (ok) {
          std::copy_n(static_cast<const int*>(symbolic->Perm), n, perm.begin());
          cholmod_free_factor(&symbolic, &common);
        }
        break;
      }
    }
    CHECK(ok) << "CHOLMOD ordering failed, status " << common.status;
    return perm;
  }
};

}  // namespace ieslam
