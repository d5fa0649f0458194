#include "backend/sparse_information.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <vector>

#include <cholmod.h>
#include <glog/logging.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "backend/sparse_cholesky_impl.h"
#include "core/stopwatch.h"

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

// C with C C^T = M for a symmetric positive semidefinite 3x3 M (Cholesky when M is
// definite; otherwise from its eigen-decomposition, negative rounding clipped).
Eigen::Matrix3d SymmetricSquareRoot(const Eigen::Matrix3d& M) {
  const Eigen::LLT<Eigen::Matrix3d> llt(M);
  if (llt.info() == Eigen::Success) return llt.matrixL();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(M);
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
}

}  // namespace

SparseCholesky::SparseCholesky(FillReducingOrdering ordering, double spare_capacity)
    : impl_(std::make_unique<Impl>(ordering, spare_capacity)) {
  CHECK_GE(spare_capacity, 0.0);
}

SparseCholesky::~SparseCholesky() = default;

bool SparseCholesky::Factorize(const UpperColumnStorage& matrix, bool /*pattern_changed*/) {
  const auto start = std::chrono::steady_clock::now();
  const int n = matrix.dim();
  const int capacity =
      impl_->spare_capacity > 0.0 ? n + static_cast<int>(impl_->spare_capacity * n) + 16 : n;
  // The matrix padded with identity slots for the variables still to come, ordered last in
  // natural order so that each new variable lands at the end of the factor.
  UpperColumnStorage padded;
  const UpperColumnStorage* to_factor = &matrix;
  if (capacity > n) {
    padded = matrix;
    for (int k = n; k < capacity; ++k) {
      padded.StartColumn();
      padded.Append(k, 1.0);
    }
    to_factor = &padded;
  }
  // The fill-reducing ordering covers the leading variables only (the first columns of the
  // upper storage are their whole submatrix); the most recent ones follow in the order
  // they were added, and then the slots: the coming updates mostly touch what was added
  // last, and their cost grows with the distance from there to the end of the order.
  const int recent = capacity > n && impl_->touched_recent >= kExploringShare
                         ? std::min(n, static_cast<int>(kRecentFraction * n))
                         : 0;
  cholmod_sparse A = ViewAsCholmod(matrix, n - recent);
  std::vector<int> perm = impl_->Ordering(&A);
  for (int k = n - recent; k < capacity; ++k) perm.push_back(k);
  cholmod_sparse P = ViewAsCholmod(*to_factor);
  impl_->common.nmethods = 1;
  impl_->common.method[0].ordering = CHOLMOD_GIVEN;
  impl_->common.postorder = 0;  // keep the slots last
  cholmod_factor* factor = cholmod_analyze_p(&P, perm.data(), nullptr, 0, &impl_->common);
  CHECK(factor != nullptr) << "CHOLMOD analysis failed, status " << impl_->common.status;
  timings_.analyze_s = SecondsSince(start);
  timings_.reordered = true;

  const auto numeric_start = std::chrono::steady_clock::now();
  const int ok = cholmod_factorize(&P, factor, &impl_->common);
  CHECK(ok || impl_->common.status == CHOLMOD_NOT_POSDEF)
      << "CHOLMOD factorisation failed, status " << impl_->common.status;
  if (!(ok != 0 && impl_->common.status == CHOLMOD_OK && factor->minor == factor->n)) {
    cholmod_free_factor(&factor, &impl_->common);
    timings_.factorize_s = SecondsSince(numeric_start);
    return false;
  }
  if (capacity > n) {
    // Simplicial LDL^T with room to grow: what cholmod_updown / cholmod_rowadd modify.
    CHECK(cholmod_change_factor(CHOLMOD_REAL, /*to_ll=*/0, /*to_super=*/0, /*to_packed=*/0,
                                /*to_monotonic=*/1, factor, &impl_->common))
        << "CHOLMOD factor conversion failed, status " << impl_->common.status;
  }
  timings_.factorize_s = SecondsSince(numeric_start);
  impl_->FreeFactor();
  impl_->factor = factor;
  impl_->numeric_ok = true;
  impl_->used = n;
  impl_->position.assign(capacity, 0);
  const int* final_perm = static_cast<const int*>(factor->Perm);
  for (int i = 0; i < capacity; ++i) impl_->position[final_perm[i]] = i;
  return true;
}

bool SparseCholesky::valid() const { return impl_->numeric_ok; }

int SparseCholesky::dim() const { return impl_->numeric_ok ? impl_->used : 0; }

void SparseCholesky::NoteUpdate(int old_dim, const std::vector<DiagonalIncrement>& increments) {
  if (increments.empty()) return;
  const int recent_start = old_dim - static_cast<int>(kExploringWindow * old_dim);
  const auto count = std::count_if(increments.begin(), increments.end(),
                                   [&](const auto& inc) { return inc.first >= recent_start; });
  impl_->touched_recent = static_cast<double>(count) / static_cast<double>(increments.size());
}

bool SparseCholesky::Update(const UpperColumnStorage& matrix, int old_dim,
                            const std::vector<DiagonalIncrement>& increments) {
  const int new_dim = matrix.dim();
  NoteUpdate(old_dim, increments);
  cholmod_factor* L = impl_->factor;
  if (!valid() || L->is_super || L->is_ll || impl_->used != old_dim ||
      new_dim > static_cast<int>(L->n)) {
    return false;
  }
  const auto start = std::chrono::steady_clock::now();
  timings_.analyze_s = 0.0;
  timings_.reordered = false;
  const std::vector<int>& position = impl_->position;
  const int n = static_cast<int>(L->n);
  cholmod_common* common = &impl_->common;

  // The re-observed features' blocks: + C C^T with C = chol(increment), rows permuted.
  if (!increments.empty()) {
    const int k = 3 * static_cast<int>(increments.size());
    cholmod_sparse* C = cholmod_allocate_sparse(n, k, 9 * increments.size(), /*sorted=*/1,
                                                /*packed=*/1, /*stype=*/0, CHOLMOD_REAL, common);
    CHECK(C != nullptr);
    int* Cp = static_cast<int*>(C->p);
    int* Ci = static_cast<int*>(C->i);
    double* Cx = static_cast<double*>(C->x);
    int nz = 0;
    for (size_t b = 0; b < increments.size(); ++b) {
      const DiagonalIncrement& increment = increments[b];
      const Eigen::Matrix3d root = SymmetricSquareRoot(increment.block);
      std::array<std::pair<int, int>, 3> rows;  // (factor row, block row), sorted
      for (int r = 0; r < 3; ++r) rows[r] = {position[increment.first + r], r};
      std::sort(rows.begin(), rows.end());
      for (int c = 0; c < 3; ++c) {
        Cp[3 * b + c] = nz;
        for (const auto& [row, r] : rows) {
          Ci[nz] = row;
          Cx[nz++] = root(r, c);
        }
      }
    }
    Cp[k] = nz;
    const int ok = cholmod_updown(/*update=*/1, C, L, common);
    cholmod_free_sparse(&C, common);
    if (!ok) {
      impl_->FreeFactor();
      return false;
    }
  }

  // The new variables, each an identity row of the factor until now.
  std::vector<std::pair<int, double>> entries;
  cholmod_sparse* R = cholmod_allocate_sparse(n, 1, new_dim, 1, 1, 0, CHOLMOD_REAL, common);
  CHECK(R != nullptr);
  for (int k = old_dim; k < new_dim; ++k) {
    entries.clear();
    for (int e = matrix.outer()[k]; e < matrix.outer()[k + 1]; ++e) {
      entries.emplace_back(position[matrix.inner()[e]], matrix.values()[e]);
    }
    std::sort(entries.begin(), entries.end());
    int* Rp = static_cast<int*>(R->p);
    Rp[0] = 0;
    Rp[1] = static_cast<int>(entries.size());
    for (size_t e = 0; e < entries.size(); ++e) {
      static_cast<int*>(R->i)[e] = entries[e].first;
      static_cast<double*>(R->x)[e] = entries[e].second;
    }
    const int row = position[k];
    const int ok = cholmod_rowadd(row, R, L, common);
    const double d = static_cast<const double*>(L->x)[static_cast<const int*>(L->p)[row]];
    if (!ok || !(d > 0.0) || !std::isfinite(d)) {
      cholmod_free_sparse(&R, common);
      impl_->FreeFactor();
      return false;
    }
  }
  cholmod_free_sparse(&R, common);
  impl_->used = new_dim;
  timings_.factorize_s = SecondsSince(start);
  return true;
}

Eigen::MatrixXd SparseCholesky::Solve(const Eigen::MatrixXd& B) const {
  CHECK(valid()) << "no valid factor";
  CHECK_EQ(B.rows(), dim());
  const int n = static_cast<int>(impl_->factor->n);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(n, B.cols());  // zero on the identity slots
  rhs.topRows(B.rows()) = B;
  cholmod_dense b = ViewAsCholmod(&rhs);
  cholmod_dense* x = cholmod_solve(CHOLMOD_A, impl_->factor, &b, &impl_->common);
  CHECK(x != nullptr) << "CHOLMOD solve failed, status " << impl_->common.status;
  Eigen::MatrixXd result =
      Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(x->x), n, B.cols())
          .topRows(B.rows());
  cholmod_free_dense(&x, &impl_->common);
  return result;
}

double SparseCholesky::LogDet() const {
  CHECK(valid()) << "no valid factor";
  const cholmod_factor& L = *impl_->factor;
  const double* x = static_cast<const double*>(L.x);
  double sum = 0.0;  // the identity slots add log 1 = 0
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

int64_t SparseCholesky::FactorNonzeros() const {
  if (!valid()) return 0;
  const cholmod_factor& L = *impl_->factor;
  if (L.is_super) return static_cast<int64_t>(impl_->common.lnz);
  int64_t count = 0;
  const int* nz = static_cast<const int*>(L.nz);
  for (size_t j = 0; j < L.n; ++j) count += nz[j];
  return count - static_cast<int64_t>(L.n) + impl_->used;  // the slots' unit diagonals
}

}  // namespace ieslam
