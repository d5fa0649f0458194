#include "backend/sparse_cholesky.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include <cholmod.h>
#include <glog/logging.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/error.h"
#include "core/stopwatch.h"

namespace ieslam {

namespace {

// A CHOLMOD view of the storage (no copy); CHOLMOD reads it only.
// `dim` < matrix.dim() views the leading principal submatrix.
cholmod_sparse ViewAsCholmod(const UpperColumnStorage& matrix, int dim = -1) {
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

// The share of the variables, the most recently added, kept out of the fill-reducing
// ordering and placed last in the order they were added, while the updates explore:
// at least kExploringShare of the re-observed blocks lie among the kExploringWindow most
// recent variables (closing a loop re-observes older ones); see Factorize().
constexpr double kRecentFraction = 0.03;
constexpr double kExploringWindow = 0.2;
constexpr double kExploringShare = 0.9;

// C with C C^T = M for a symmetric positive semidefinite 3x3 M (Cholesky when M is
// definite; otherwise from its eigen-decomposition, negative rounding clipped).
Eigen::Matrix3d SymmetricSquareRoot(const Eigen::Matrix3d& M) {
  const Eigen::LLT<Eigen::Matrix3d> llt(M);
  if (llt.info() == Eigen::Success) return llt.matrixL();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(M);
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
}

// The same for a 6x6 M (a pose's increment, of rank 3 for one sighting: eigen-decomposed).
Eigen::Matrix<double, 6, 6> SymmetricSquareRoot(const Eigen::Matrix<double, 6, 6>& M) {
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(M);
  if (llt.info() == Eigen::Success) return llt.matrixL();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(M);
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
}

// Appends the columns of `root` (C C^T = the increment of the diagonal block at `first`) to
// C, its rows at their factor positions, sorted.
template <int N>
void AppendRootColumns(const Eigen::Matrix<double, N, N>& root, int first,
                       const std::vector<int>& position, int* column, int* Cp, int* Ci, double* Cx,
                       int* nz) {
  std::array<std::pair<int, int>, N> rows;  // (factor row, block row), sorted
  for (int r = 0; r < N; ++r) rows[r] = {position[first + r], r};
  std::sort(rows.begin(), rows.end());
  for (int c = 0; c < N; ++c) {
    Cp[(*column)++] = *nz;
    for (const auto& [row, r] : rows) {
      Ci[*nz] = row;
      Cx[(*nz)++] = root(r, c);
    }
  }
}

// Y^T Y for the rows of Y listed in `rows` (others are zero), exactly symmetric.
Eigen::MatrixXd GramOfRows(const Eigen::MatrixXd& Y_rows) {
  const int k = static_cast<int>(Y_rows.cols());
  Eigen::MatrixXd result = Eigen::MatrixXd::Zero(k, k);
  result.selfadjointView<Eigen::Lower>().rankUpdate(Y_rows.transpose());
  result.triangularView<Eigen::StrictlyUpper>() = result.transpose();
  return result;
}

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Forward solves D^-1/2 L^-1 e_j of unit columns on a simplicial L D L^T factor (unit
// diagonal in L), each over its elimination-tree path only (parent = first row below the
// diagonal).
class PathSolver {
 public:
  explicit PathSolver(const cholmod_factor& L)
      : Lp_(static_cast<const int*>(L.p)),
        Li_(static_cast<const int*>(L.i)),
        Lnz_(static_cast<const int*>(L.nz)),
        Lx_(static_cast<const double*>(L.x)),
        parent_(L.n, -2),
        row_of_(L.n, -1) {}

  // The solutions for the unit columns at factor rows `targets`, on `*rows`: the union of
  // their paths, ascending. Row by row in factor order (row-major, so each step is a
  // contiguous axpy over the columns).
  RowMajor Solve(const std::vector<int>& targets, std::vector<int>* rows) {
    rows->clear();
    for (const int target : targets) {
      for (int j = target; j >= 0 && row_of_[j] < 0;) {
        row_of_[j] = 0;
        rows->push_back(j);
        if (parent_[j] == -2) parent_[j] = Parent(j);
        j = parent_[j];
      }
    }
    std::sort(rows->begin(), rows->end());
    for (size_t r = 0; r < rows->size(); ++r) row_of_[(*rows)[r]] = static_cast<int>(r);
    const int width = static_cast<int>(targets.size());
    RowMajor Y = RowMajor::Zero(static_cast<int>(rows->size()), width);
    for (int c = 0; c < width; ++c) Y(row_of_[targets[c]], c) = 1.0;
    for (size_t r = 0; r < rows->size(); ++r) {
      const int j = (*rows)[r];
      for (int e = Lp_[j] + 1; e < Lp_[j] + Lnz_[j]; ++e) {
        const int target = row_of_[Li_[e]];
        CHECK_GE(target, 0) << "row " << Li_[e] << " of column " << j << " is off its path";
        Y.row(target) -= Lx_[e] * Y.row(static_cast<Eigen::Index>(r));
      }
    }
    for (size_t r = 0; r < rows->size(); ++r) {
      Y.row(r) /= std::sqrt(Lx_[Lp_[(*rows)[r]]]);  // D^-1/2
      row_of_[(*rows)[r]] = -1;
    }
    return Y;
  }

 private:
  int Parent(int j) const {
    int parent = -1;
    for (int e = Lp_[j] + 1; e < Lp_[j] + Lnz_[j]; ++e) {
      if (parent < 0 || Li_[e] < parent) parent = Li_[e];
    }
    return parent;
  }

  const int* Lp_;
  const int* Li_;
  const int* Lnz_;
  const double* Lx_;
  std::vector<int> parent_;  // -2: not looked up yet
  std::vector<int> row_of_;  // factor row -> row of the current solve's Y (-1: none)
};

}  // namespace

bool SparseCholeskyOptions::Check(std::string* why) const {
  std::ostringstream reason;
  if (!(spare_capacity >= 0.0) || !std::isfinite(spare_capacity)) {
    reason << "spare_capacity must be >= 0 and finite, got " << spare_capacity;
  }
  if (why != nullptr) *why = reason.str();
  return reason.str().empty();
}

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

  // + C C^T on the factor, C = chol(increment) per block with its rows permuted: the
  // re-observed features' blocks and the earlier poses'. False (the factor freed) if CHOLMOD
  // fails.
  bool AddIncrements(const std::vector<DiagonalIncrement>& increments,
                     const std::vector<PoseIncrement>& pose_increments) {
    const int n = static_cast<int>(factor->n);
    const int k =
        3 * static_cast<int>(increments.size()) + 6 * static_cast<int>(pose_increments.size());
    cholmod_sparse* C =
        cholmod_allocate_sparse(n, k, 9 * increments.size() + 36 * pose_increments.size(),
                                /*sorted=*/1, /*packed=*/1, /*stype=*/0, CHOLMOD_REAL, &common);
    CHECK(C != nullptr);
    int* Cp = static_cast<int*>(C->p);
    int* Ci = static_cast<int*>(C->i);
    double* Cx = static_cast<double*>(C->x);
    int nz = 0, column = 0;
    for (const DiagonalIncrement& increment : increments) {
      AppendRootColumns<3>(SymmetricSquareRoot(increment.block), increment.first, position, &column,
                           Cp, Ci, Cx, &nz);
    }
    for (const PoseIncrement& increment : pose_increments) {
      AppendRootColumns<6>(SymmetricSquareRoot(increment.block), increment.first, position, &column,
                           Cp, Ci, Cx, &nz);
    }
    Cp[k] = nz;
    const int ok = cholmod_updown(/*update=*/1, C, factor, &common);
    cholmod_free_sparse(&C, &common);
    if (!ok) FreeFactor();
    return ok != 0;
  }

  // The new variables [old_dim, matrix.dim()), each an identity row of the factor until
  // now. False (the factor freed) if the result is not positive definite.
  bool AddRows(const UpperColumnStorage& matrix, int old_dim) {
    const int n = static_cast<int>(factor->n);
    const int new_dim = matrix.dim();
    std::vector<std::pair<int, double>> entries;
    cholmod_sparse* R = cholmod_allocate_sparse(n, 1, new_dim, 1, 1, 0, CHOLMOD_REAL, &common);
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
      const int ok = cholmod_rowadd(row, R, factor, &common);
      const double d =
          static_cast<const double*>(factor->x)[static_cast<const int*>(factor->p)[row]];
      if (!ok || !(d > 0.0) || !std::isfinite(d)) {
        cholmod_free_sparse(&R, &common);
        FreeFactor();
        return false;
      }
    }
    cholmod_free_sparse(&R, &common);
    return true;
  }
};

SparseCholesky::SparseCholesky(const SparseCholeskyOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("SparseCholeskyOptions: " + why);
  impl_ = std::make_unique<Impl>(options.ordering, options.spare_capacity);
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

void SparseCholesky::NoteUpdate(int old_dim, const std::vector<DiagonalIncrement>& increments,
                                const std::vector<PoseIncrement>& pose_increments) {
  const size_t total = increments.size() + pose_increments.size();
  if (total == 0) return;
  const int recent_start = old_dim - static_cast<int>(kExploringWindow * old_dim);
  const auto recent = [&](const auto& inc) { return inc.first >= recent_start; };
  const auto count = std::count_if(increments.begin(), increments.end(), recent) +
                     std::count_if(pose_increments.begin(), pose_increments.end(), recent);
  impl_->touched_recent = static_cast<double>(count) / static_cast<double>(total);
}

bool SparseCholesky::Update(const UpperColumnStorage& matrix, int old_dim,
                            const std::vector<DiagonalIncrement>& increments,
                            const std::vector<PoseIncrement>& pose_increments) {
  const int new_dim = matrix.dim();
  NoteUpdate(old_dim, increments, pose_increments);
  cholmod_factor* L = impl_->factor;
  if (!valid() || L->is_super || L->is_ll || impl_->used != old_dim ||
      new_dim > static_cast<int>(L->n)) {
    return false;
  }
  const auto start = std::chrono::steady_clock::now();
  timings_.analyze_s = 0.0;
  timings_.reordered = false;
  if ((!increments.empty() || !pose_increments.empty()) &&
      !impl_->AddIncrements(increments, pose_increments)) {
    return false;
  }
  if (!impl_->AddRows(matrix, old_dim)) return false;
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

  // The columns are solved in chunks of kChunk, each over its own paths' union only: a
  // chunk's rows stay in cache, where all k columns at once would stream megabytes per
  // factor column, and nearby variables share most of their paths. The columns are taken
  // sorted by factor position, so that a chunk holds nearby variables.
  constexpr int kChunk = 48;
  std::vector<int> column_order(k);
  for (int c = 0; c < k; ++c) column_order[c] = c;
  std::sort(column_order.begin(), column_order.end(),
            [&](int a, int b) { return position[indices[a]] < position[indices[b]]; });
  PathSolver solver(L);
  std::vector<int> all_of(n, -1);  // factor row -> row of the whole compact Y
  std::vector<int> all_rows;
  std::vector<RowMajor> chunk_y;
  std::vector<std::vector<int>> chunk_rows;
  for (int c0 = 0; c0 < k; c0 += kChunk) {
    std::vector<int> targets;
    for (int c = c0; c < std::min(k, c0 + kChunk); ++c) {
      targets.push_back(position[indices[column_order[c]]]);
    }
    std::vector<int> rows;
    chunk_y.push_back(solver.Solve(targets, &rows));
    for (const int row : rows) {
      if (all_of[row] < 0) {
        all_of[row] = 0;
        all_rows.push_back(row);
      }
    }
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
