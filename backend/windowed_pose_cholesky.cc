#include "backend/windowed_pose_cholesky.h"

#include <algorithm>
#include <utility>

#include <glog/logging.h>
#include <Eigen/Cholesky>

namespace ieslam {

namespace {

// Lower Cholesky factor of T in place; false unless T is positive definite.
template <typename Matrix>
bool FactorInPlace(Matrix* T) {
  if (T->rows() == 0) return true;
  Eigen::LLT<Eigen::Ref<Matrix>> llt(*T);
  if (llt.info() != Eigen::Success) return false;
  const auto diagonal = T->diagonal();
  return diagonal.allFinite() && diagonal.minCoeff() > 0.0;
}

// v = (L L^T)^-1 v for a lower triangular L.
template <typename Matrix, typename Vector>
void SubstituteInPlace(const Matrix& L, Vector* v) {
  const auto lower = L.template triangularView<Eigen::Lower>();
  lower.solveInPlace(*v);
  lower.transpose().solveInPlace(*v);
}

// The first `columns` columns of L for the positions from `first` of `order`, rows in their
// new places (`position`: pose -> old position; poses from `factored` on have none).
template <typename Matrix>
Matrix LeadingColumns(const Matrix& L, int first, int columns, const std::vector<int>& order,
                      const std::vector<int>& position, int factored) {
  const int rows = 6 * (static_cast<int>(order.size()) - first);
  Matrix lead = Matrix::Zero(rows, columns);
  if (columns == 0) return lead;
  for (int q = first; q < static_cast<int>(order.size()); ++q) {
    const int pose = order[q];
    if (pose >= factored) continue;  // not factored: none before
    lead.template middleRows<6>(6 * (q - first)) = L.block(6 * position[pose], 0, 6, columns);
  }
  return lead;
}

// S's block of the positions from `first` of `order` (pose per position), in that order:
// the 6x6 blocks on and below the diagonal only (the rest is left unset), each read from
// S's lower blocks (in pose order; S keeps no others). By blocks: an indexed view of the
// scalar rows gathers coefficient by coefficient, several times slower.
template <typename Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> GatherLower(const Eigen::MatrixXd& S,
                                                                  const std::vector<int>& order,
                                                                  int first) {
  const int m = static_cast<int>(order.size()) - first;
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> T(6 * m, 6 * m);
  for (int b = 0; b < m; ++b) {
    const int col_pose = order[first + b];
    for (int a = b; a < m; ++a) {
      const int row_pose = order[first + a];
      if (row_pose >= col_pose) {
        T.template block<6, 6>(6 * a, 6 * b) =
            S.block<6, 6>(6 * row_pose, 6 * col_pose).template cast<Scalar>();
      } else {
        T.template block<6, 6>(6 * a, 6 * b) =
            S.block<6, 6>(6 * col_pose, 6 * row_pose).transpose().template cast<Scalar>();
      }
    }
  }
  return T;
}

// Rows of a block and the rows of a source they take, from a map block row -> source row
// (-1: none).
void GatherRows(const std::vector<int>& source_row, std::vector<int>* rows,
                std::vector<int>* source_rows) {
  for (int r = 0; r < static_cast<int>(source_row.size()); ++r) {
    if (source_row[r] < 0) continue;
    rows->push_back(r);
    source_rows->push_back(source_row[r]);
  }
}

}  // namespace

WindowedPoseCholesky::WindowedPoseCholesky(int prefetch, int evict_after)
    : prefetch_(prefetch), evict_after_(evict_after) {}

std::vector<int> WindowedPoseCholesky::AddPose(const std::vector<int>& touched) {
  std::vector<int> previous;
  previous.reserve(touched.size());
  for (const int pose : touched) {
    previous.push_back(last_touched_[pose]);
    last_touched_[pose] = updates_;
  }
  last_touched_.push_back(updates_);
  ++updates_;
  return previous;
}

void WindowedPoseCholesky::RemoveLastPose(const std::vector<int>& touched,
                                          const std::vector<int>& previous) {
  CHECK_EQ(touched.size(), previous.size());
  --updates_;
  last_touched_.pop_back();
  for (size_t i = 0; i < touched.size(); ++i) last_touched_[touched[i]] = previous[i];
}

std::vector<int> WindowedPoseCholesky::DirtyPoses() const {
  std::vector<int> dirty;
  for (int pose = 0; pose < num_factored(); ++pose) {
    if (last_touched_[pose] >= exact_since_update_) dirty.push_back(pose);
  }
  return dirty;
}

WindowedPoseCholesky::Plan WindowedPoseCholesky::PlanWindow(const std::vector<int>& touched) const {
  // Window positions: evicted poses first, then the ones kept, then anything moved in from
  // the leading part, then the poses not yet factored.
  const int k = num_factored();
  const int lead = window_start_;
  std::vector<int> evicted, kept;
  for (int q = lead; q < k; ++q) {
    const int pose = order_[q];
    (last_touched_[pose] + evict_after_ <= updates_ ? evicted : kept).push_back(pose);
  }
  std::vector<char> move(k, 0);
  for (const int pose : touched) {
    if (position_[pose] >= lead) continue;
    for (int q = std::max(0, pose - prefetch_); q <= std::min(k - 1, pose + prefetch_); ++q) {
      move[q] = position_[q] < lead;
    }
  }
  Plan plan;
  plan.first = lead;
  for (int q = 0; q < k; ++q) {
    if (move[q]) plan.first = std::min(plan.first, position_[q]);
  }
  std::vector<int>& order = plan.order;
  order.assign(order_.begin(), order_.begin() + plan.first);
  for (int q = plan.first; q < lead; ++q) {
    if (!move[order_[q]]) order.push_back(order_[q]);
  }
  order.insert(order.end(), evicted.begin(), evicted.end());
  plan.window_start = static_cast<int>(order.size());
  order.insert(order.end(), kept.begin(), kept.end());
  for (int q = 0; q < k; ++q) {
    if (move[q]) order.push_back(q);
  }
  for (int pose = k; pose < num_poses(); ++pose) order.push_back(pose);
  return plan;
}

WindowedPoseCholesky::Plan WindowedPoseCholesky::PlanAll() const {
  std::vector<int> lead, window;
  for (int q = 0; q < num_poses(); ++q) {
    (last_touched_[q] + evict_after_ <= updates_ ? lead : window).push_back(q);
  }
  Plan plan;
  plan.order = lead;
  plan.order.insert(plan.order.end(), window.begin(), window.end());
  plan.window_start = static_cast<int>(lead.size());
  return plan;
}

Eigen::MatrixXd WindowedPoseCholesky::UpdatedWindow(const Plan& plan, const std::vector<int>& local,
                                                    const Eigen::MatrixXd& D) const {
  // The trailing block is C plus the change, in the new window order.
  const int k = num_factored();  // the new pose
  const int t = static_cast<int>(D.rows()) / 6 - 1;
  const int lead = window_start_;
  const std::vector<int>& order = plan.order;
  const int m = 6 * (k + 1 - lead);
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(m, m);
  std::vector<int> from(m);  // new window row -> old C row (-1: the new pose)
  for (int q = lead; q <= k; ++q) {
    const int old_q = order[q] == k ? -1 : position_[order[q]] - lead;
    for (int c = 0; c < 6; ++c) from[6 * (q - lead) + c] = old_q < 0 ? -1 : 6 * old_q + c;
  }
  std::vector<int> rows, old_rows;
  GatherRows(from, &rows, &old_rows);
  T(rows, rows) = C_(old_rows, old_rows);
  std::vector<int> d_rows(m);  // new window row -> row of D (-1: untouched)
  for (int q = lead; q <= k; ++q) {
    const int pose = order[q];
    const int l = pose == k ? t : local[pose];
    for (int c = 0; c < 6; ++c) d_rows[6 * (q - lead) + c] = l < 0 ? -1 : 6 * l + c;
  }
  std::vector<int> w_rows, dd_rows;
  GatherRows(d_rows, &w_rows, &dd_rows);
  T(w_rows, w_rows) += D(dd_rows, dd_rows);
  return T;
}

bool WindowedPoseCholesky::FactorFrom(const Plan& plan, const Eigen::MatrixXd& S,
                                      const Eigen::MatrixXd* trailing) {
  // After a renewal in float only the leading columns it kept are exact: the order's prefix
  // up to `first` is the old one, so starting earlier changes nothing else.
  CHECK(trailing == nullptr || plan.first <= double_columns_);
  const int first = std::min(plan.first, double_columns_);
  const std::vector<int>& order = plan.order;
  const int n = dim();
  CHECK_GE(L_.rows(), n) << "no room in L";
  const int f6 = 6 * first, w6 = 6 * plan.window_start;
  // The unchanged leading columns of L, rows moved to their new positions.
  const Eigen::MatrixXd L_lead = LeadingColumns(L_, first, f6, order, position_, num_factored());
  Eigen::MatrixXd T;
  if (trailing != nullptr) {
    T = *trailing;
  } else {
    T = GatherLower<double>(S, order, first);
    if (f6 > 0 && T.rows() > 0) T.selfadjointView<Eigen::Lower>().rankUpdate(L_lead, -1.0);
  }
  // Factor the part before the window, then the window's Schur complement C.
  const int a = w6 - f6, m = n - w6;
  Eigen::MatrixXd L11 = T.topLeftCorner(a, a);
  if (!FactorInPlace(&L11)) return false;
  Eigen::MatrixXd L21 = T.bottomLeftCorner(m, a);
  // Empty blocks are skipped: Eigen's triangular solve binds a reference to their (null) data.
  if (a > 0 && m > 0) {
    L11.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(L21);
  }
  Eigen::MatrixXd C = T.bottomRightCorner(m, m);
  if (a > 0 && m > 0) C.selfadjointView<Eigen::Lower>().rankUpdate(L21, -1.0);
  C.triangularView<Eigen::StrictlyUpper>() = C.transpose();
  Eigen::MatrixXd L22 = C;
  if (!FactorInPlace(&L22)) return false;

  L_.block(f6, 0, n - f6, f6) = L_lead;
  L_.block(f6, f6, a, a) = L11.triangularView<Eigen::Lower>();
  L_.block(w6, f6, m, a) = L21;
  L_.block(w6, w6, m, m) = L22.triangularView<Eigen::Lower>();
  C_ = std::move(C);
  double_columns_ = static_cast<int>(order.size());
  single_rows_ = std::min(single_rows_, first);
  Commit(order, plan.window_start);
  return true;
}

bool WindowedPoseCholesky::RenewInSingle(const Plan& plan, const Eigen::MatrixXd& S) {
  SyncSingle();
  const int first = plan.first;
  const std::vector<int>& order = plan.order;
  const int n = dim(), f6 = 6 * first;
  CHECK_GE(L_.rows(), n) << "no room in L";
  const int factored = num_factored();
  const int kept = std::min(first, double_columns_);
  const Eigen::MatrixXd lead = LeadingColumns(L_, first, 6 * kept, order, position_, factored);
  const Eigen::MatrixXf lead_single =
      LeadingColumns(L_single_, first, f6, order, position_, factored);
  Eigen::MatrixXf T = GatherLower<float>(S, order, first);
  if (f6 > 0 && T.rows() > 0) T.selfadjointView<Eigen::Lower>().rankUpdate(lead_single, -1.0f);
  if (!FactorInPlace(&T)) return false;

  if (L_single_.size() == 0) L_single_.resize(L_.rows(), L_.cols());
  L_single_.block(f6, 0, n - f6, f6) = lead_single;
  L_single_.block(f6, f6, n - f6, n - f6) = T.triangularView<Eigen::Lower>();
  L_.block(f6, 0, n - f6, 6 * kept) = lead;
  double_columns_ = kept;
  single_rows_ = static_cast<int>(order.size());
  Commit(order, plan.window_start);
  return true;
}

void WindowedPoseCholesky::SyncSingle() {
  const int factored = num_factored();
  if (single_rows_ >= factored) return;
  CHECK_EQ(double_columns_, factored) << "neither factor is up to date";
  const int n = 6 * factored, r6 = 6 * single_rows_;
  if (L_single_.rows() < L_.rows()) L_single_.conservativeResize(L_.rows(), L_.cols());
  L_single_.block(r6, 0, n - r6, n) = L_.block(r6, 0, n - r6, n).cast<float>();
  single_rows_ = factored;
}

void WindowedPoseCholesky::Reserve(int capacity) {
  if (L_.rows() >= capacity) return;
  L_.conservativeResize(capacity, capacity);
  if (L_single_.size() > 0) L_single_.conservativeResize(capacity, capacity);
}

void WindowedPoseCholesky::Commit(const std::vector<int>& order, int window_start) {
  order_ = order;
  position_.assign(order.size(), -1);
  for (int q = 0; q < static_cast<int>(order.size()); ++q) position_[order[q]] = q;
  window_start_ = window_start;
  valid_ = true;
  exact_since_update_ = updates_;
}

void WindowedPoseCholesky::PlaceUnfactored() {
  position_.resize(num_poses());
  for (int pose = num_factored(); pose < num_poses(); ++pose) position_[pose] = pose;
}

void WindowedPoseCholesky::Substitute(Eigen::Ref<Eigen::VectorXd> z, bool single) const {
  const int n = static_cast<int>(z.size());
  if (single) {
    Eigen::VectorXf w = z.cast<float>();
    SubstituteInPlace(L_single_.topLeftCorner(n, n), &w);
    z = w.cast<double>();
  } else {
    SubstituteInPlace(L_.topLeftCorner(n, n), &z);
  }
}

double WindowedPoseCholesky::LogDetS() const {
  CHECK(exact()) << "no exact factor";
  return 2.0 * L_.topLeftCorner(dim(), dim()).diagonal().array().log().sum();
}

Eigen::MatrixXd WindowedPoseCholesky::QuadraticForm(const Eigen::MatrixXd& R,
                                                    const std::vector<int>& first_row) const {
  CHECK(exact()) << "no exact factor";
  const int n = dim(), k = static_cast<int>(R.cols());
  CHECK_EQ(R.rows(), n);
  // Groups from each one's first row down: the features a buffer sees were first seen at
  // very different times when the path loops, and skipping the zero tops saves work.
  std::vector<int> sorted(k);
  for (int col = 0; col < k; ++col) sorted[col] = col;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [&](int a, int b) { return first_row[a] < first_row[b]; });
  constexpr int kGroupColumns = 48;  // wide enough for efficient blocked solves and products
  struct Group {
    std::vector<int> columns;
    int first = 0;
    Eigen::MatrixXd Z;  // L^-1 R, rows first..n-1
  };
  std::vector<Group> groups;
  for (int start = 0; start < k; start += kGroupColumns) {
    Group group;
    const int end = std::min(k, start + kGroupColumns);
    group.columns.assign(sorted.begin() + start, sorted.begin() + end);
    group.first = first_row[group.columns.front()];
    if (group.first >= n) continue;  // columns that are all zero add nothing
    group.Z = R(Eigen::seq(group.first, n - 1), group.columns);
    L_.block(group.first, group.first, n - group.first, n - group.first)
        .triangularView<Eigen::Lower>()
        .solveInPlace(group.Z);
    groups.push_back(std::move(group));
  }
  // R^T S^-1 R = Z^T Z.
  Eigen::MatrixXd result = Eigen::MatrixXd::Zero(k, k);
  for (size_t a = 0; a < groups.size(); ++a) {
    for (size_t b = a; b < groups.size(); ++b) {
      Eigen::MatrixXd block;
      if (a == b) {  // symmetric: half the work
        block.setZero(groups[a].Z.cols(), groups[a].Z.cols());
        block.selfadjointView<Eigen::Lower>().rankUpdate(groups[a].Z.transpose());
        block.triangularView<Eigen::StrictlyUpper>() = block.transpose();
      } else {
        const int rows = n - groups[b].first;  // groups[b].first >= groups[a].first
        block.noalias() = groups[a].Z.bottomRows(rows).transpose() * groups[b].Z;
      }
      for (size_t i = 0; i < groups[a].columns.size(); ++i) {
        for (size_t j = 0; j < groups[b].columns.size(); ++j) {
          result(groups[a].columns[i], groups[b].columns[j]) = block(i, j);
          result(groups[b].columns[j], groups[a].columns[i]) = block(i, j);
        }
      }
    }
  }
  return result;
}

}  // namespace ieslam
