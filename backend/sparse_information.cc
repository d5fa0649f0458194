#include "backend/sparse_information.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <cholmod.h>
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

namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// A CHOLMOD view of the storage (no copy); CHOLMOD reads it only.
cholmod_sparse ViewAsCholmod(const UpperColumnStorage& matrix) {
  cholmod_sparse A{};
  A.nrow = A.ncol = static_cast<size_t>(matrix.dim());
  A.nzmax = static_cast<size_t>(matrix.nonzeros());
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

cholmod_dense ViewAsCholmod(Eigen::MatrixXd* B) {
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

}  // namespace

struct SparseCholesky::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  bool numeric_ok = false;

  explicit Impl(FillReducingOrdering ordering) {
    cholmod_start(&common);
    common.print = 0;  // failures are reported through return values, not stdout
    common.supernodal = CHOLMOD_SUPERNODAL;
    common.final_asis = 1;
    switch (ordering) {
      case FillReducingOrdering::kAmd:
        common.nmethods = 1;
        common.method[0].ordering = CHOLMOD_AMD;
        break;
      case FillReducingOrdering::kNatural:
        common.nmethods = 1;
        common.method[0].ordering = CHOLMOD_NATURAL;
        break;
      case FillReducingOrdering::kCholmodChoice:
        break;
    }
  }
  ~Impl() {
    FreeFactor();
    cholmod_finish(&common);
  }
  void FreeFactor() {
    if (factor != nullptr) cholmod_free_factor(&factor, &common);
    numeric_ok = false;
  }
};

SparseCholesky::SparseCholesky(FillReducingOrdering ordering)
    : impl_(std::make_unique<Impl>(ordering)) {}

SparseCholesky::~SparseCholesky() = default;

bool SparseCholesky::Factorize(const UpperColumnStorage& matrix, bool pattern_changed) {
  cholmod_sparse A = ViewAsCholmod(matrix);
  if (impl_->factor == nullptr || pattern_changed ||
      impl_->factor->n != static_cast<size_t>(matrix.dim())) {
    const auto start = std::chrono::steady_clock::now();
    impl_->FreeFactor();
    impl_->factor = cholmod_analyze(&A, &impl_->common);
    CHECK(impl_->factor != nullptr) << "CHOLMOD analysis failed, status " << impl_->common.status;
    timings_.analyze_s = SecondsSince(start);
  } else {
    timings_.analyze_s = 0.0;
  }
  const auto start = std::chrono::steady_clock::now();
  const int ok = cholmod_factorize(&A, impl_->factor, &impl_->common);
  timings_.factorize_s = SecondsSince(start);
  impl_->numeric_ok = ok != 0 && impl_->common.status == CHOLMOD_OK &&
                      impl_->factor->minor == impl_->factor->n;
  CHECK(ok || impl_->common.status == CHOLMOD_NOT_POSDEF)
      << "CHOLMOD factorisation failed, status " << impl_->common.status;
  return impl_->numeric_ok;
}

bool SparseCholesky::valid() const { return impl_->numeric_ok; }

int SparseCholesky::dim() const {
  return impl_->factor == nullptr ? 0 : static_cast<int>(impl_->factor->n);
}

Eigen::MatrixXd SparseCholesky::Solve(const Eigen::MatrixXd& B) const {
  CHECK(valid()) << "no valid factor";
  CHECK_EQ(B.rows(), dim());
  Eigen::MatrixXd rhs = B;
  cholmod_dense b = ViewAsCholmod(&rhs);
  cholmod_dense* x = cholmod_solve(CHOLMOD_A, impl_->factor, &b, &impl_->common);
  CHECK(x != nullptr) << "CHOLMOD solve failed, status " << impl_->common.status;
  Eigen::MatrixXd result =
      Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(x->x), B.rows(), B.cols());
  cholmod_free_dense(&x, &impl_->common);
  return result;
}

double SparseCholesky::LogDet() const {
  CHECK(valid()) << "no valid factor";
  const cholmod_factor& L = *impl_->factor;
  const double* x = static_cast<const double*>(L.x);
  double sum = 0.0;
  if (L.is_super) {
    const int* super = static_cast<const int*>(L.super);
    const int* pi = static_cast<const int*>(L.pi);
    const int* px = static_cast<const int*>(L.px);
    for (size_t s = 0; s < L.nsuper; ++s) {
      // Each supernode is a dense column-major block of nsrow rows; its leading square
      // holds the diagonal.
      const int nsrow = pi[s + 1] - pi[s];
      for (int j = 0; j < super[s + 1] - super[s]; ++j) sum += std::log(x[px[s] + j * nsrow + j]);
    }
    return 2.0 * sum;
  }
  const int* p = static_cast<const int*>(L.p);
  for (size_t j = 0; j < L.n; ++j) sum += std::log(x[p[j]]);
  return L.is_ll ? 2.0 * sum : sum;  // LDL^T keeps D on the diagonal
}

Eigen::MatrixXd SparseCholesky::InverseSubmatrix(const std::vector<int>& indices) const {
  CHECK(valid()) << "no valid factor";
  const int n = dim();
  const int k = static_cast<int>(indices.size());
  constexpr int kChunk = 32;
  Eigen::MatrixXd result(k, k);
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(n, std::min(k, kChunk));
  for (int first = 0; first < k; first += kChunk) {
    const int count = std::min(kChunk, k - first);
    if (count != unit.cols()) unit = Eigen::MatrixXd::Zero(n, count);
    for (int c = 0; c < count; ++c) {
      CHECK(indices[first + c] >= 0 && indices[first + c] < n) << indices[first + c];
      unit(indices[first + c], c) = 1.0;
    }
    const Eigen::MatrixXd columns = Solve(unit);
    for (int c = 0; c < count; ++c) {
      unit(indices[first + c], c) = 0.0;
      for (int r = 0; r < k; ++r) result(r, first + c) = columns(indices[r], c);
    }
  }
  // Symmetric up to rounding; make it exactly so for the callers' Cholesky factors.
  return 0.5 * (result + result.transpose());
}

int64_t SparseCholesky::FactorNonzeros() const {
  return impl_->factor == nullptr ? 0 : static_cast<int64_t>(impl_->common.lnz);
}

}  // namespace ieslam
