#include "backend/pose_schur_factor.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <glog/logging.h>
#include <Eigen/Cholesky>

namespace ieslam {

namespace {

using Matrix63 = PoseSchurFactor::Matrix63;

// F^-1 for a symmetric positive definite 3x3 F, exactly symmetric.
Eigen::Matrix3d SymmetricInverse(const Eigen::Matrix3d& F) {
  Eigen::Matrix3d inverse = F.llt().solve(Eigen::Matrix3d::Identity());
  return 0.5 * (inverse + inverse.transpose());
}

// Lower Cholesky factor of T in place; false unless T is positive definite.
template <typename Matrix>
bool FactorInPlace(Matrix* T) {
  if (T->rows() == 0) return true;
  Eigen::LLT<Eigen::Ref<Matrix>> llt(*T);
  if (llt.info() != Eigen::Success) return false;
  const auto diagonal = T->diagonal();
  return diagonal.allFinite() && diagonal.minCoeff() > 0.0;
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
// scalar rows gathers coefficient by coefficient, ~3x slower.
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

}  // namespace

PoseSchurFactor::PoseSchurFactor(const PoseSchurOptions& options) : options_(options) {
  CHECK_GE(options_.prefetch, 0);
  CHECK_GE(options_.evict_after, 1);
  CHECK_GE(options_.cg_flop_weight, 0.0);
  CHECK_GE(options_.single_speedup, 0.0);
}

void PoseSchurFactor::Grow(int n) {
  if (S_.rows() >= n) return;
  // Room for 100 more poses: a copy every 100 poses, and little memory wasted.
  const int capacity = n + 600;
  S_.conservativeResize(capacity, capacity);
  L_.conservativeResize(capacity, capacity);
  if (L_single_.size() > 0) L_single_.conservativeResize(capacity, capacity);
}

bool PoseSchurFactor::AddPose(int pose_offset, const Eigen::Matrix<double, 6, 6>& I_pp,
                              const std::vector<SchurObservation>& observations,
                              SchurUpdate update) {
  CHECK_EQ(pose_of_offset_.count(pose_offset), 0u) << "pose offset " << pose_offset << " taken";
  const int k = num_poses();
  const bool was_exact = exact();
  // The poses whose Schur blocks change: every pose that saw a re-observed feature.
  std::vector<int> touched;
  for (const SchurObservation& obs : observations) {
    if (obs.is_new) continue;
    const auto it = feature_of_offset_.find(obs.feature_offset);
    CHECK(it != feature_of_offset_.end()) << "no feature at offset " << obs.feature_offset;
    const Feature& feature = features_[it->second];
    touched.insert(touched.end(), feature.poses.begin(), feature.poses.end());
  }
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  const int t = static_cast<int>(touched.size());
  const bool chosen = update == SchurUpdate::kLazy && valid_ && t > 0;
  const Choice choice = chosen ? ChooseUpdate(touched) : Choice::kExact;
  // A renewal, or an exact update that refactors from S (not from the window's C), takes
  // the update in lazily first (checking that S stays positive definite), then brings S up
  // to date in one pass over the features this and the lazy updates changed.
  const bool lazy = chosen && (choice != Choice::kExact || !was_exact);
  // Anything else changes S itself: first the lazy updates' changes.
  if (!lazy) Sync();

  // D: the change of S on the touched poses and the new pose's row (local block t).
  std::vector<int> local(k, -1);
  for (int i = 0; i < t; ++i) local[touched[i]] = i;
  Eigen::MatrixXd D;
  if (!lazy) {
    D = Eigen::MatrixXd::Zero(6 * (t + 1), 6 * (t + 1));
    D.bottomRightCorner<6, 6>() = I_pp;
  }
  std::vector<Eigen::Matrix3d> new_inverse(observations.size());
  for (size_t o = 0; o < observations.size(); ++o) {
    const SchurObservation& obs = observations[o];
    const Matrix63& G = obs.I_pf;
    if (obs.is_new) {
      new_inverse[o] = SymmetricInverse(obs.I_ff);
      if (!lazy) D.bottomRightCorner<6, 6>() -= G * new_inverse[o] * G.transpose();
      continue;
    }
    const Feature& feature = features_[feature_of_offset_.at(obs.feature_offset)];
    const Eigen::Matrix3d F_inv_new = SymmetricInverse(feature.F + obs.I_ff);
    new_inverse[o] = F_inv_new;
    if (lazy) continue;
    // F^-1 - F'^-1 = F^-1 A F'^-1 without the cancellation of the difference.
    Eigen::Matrix3d M = feature.F_inv * obs.I_ff * F_inv_new;
    M = 0.5 * (M + M.transpose());
    const int p = static_cast<int>(feature.poses.size());
    std::vector<Eigen::Matrix<double, 3, 6>> MBt(p);
    for (int a = 0; a < p; ++a) MBt[a] = M * feature.couplings[a].transpose();
    for (int a = 0; a < p; ++a) {
      const int la = local[feature.poses[a]];
      for (int b = 0; b < p; ++b) {
        const int lb = local[feature.poses[b]];
        if (lb < la) continue;
        D.block<6, 6>(6 * la, 6 * lb).noalias() += feature.couplings[a] * MBt[b];
      }
      D.block<6, 6>(6 * la, 6 * t).noalias() -= feature.couplings[a] * F_inv_new * G.transpose();
    }
    D.bottomRightCorner<6, 6>() -= G * F_inv_new * G.transpose();
  }

  // Apply to S (unless lazy) and the features, keeping what a failure has to restore.
  const int old_n = dim();
  std::vector<int> scalar;  // S rows of the touched poses
  Eigen::MatrixXd S_saved;
  if (!lazy) {
    D.triangularView<Eigen::StrictlyLower>() = D.transpose();
    for (const int pose : touched) {
      for (int c = 0; c < 6; ++c) scalar.push_back(6 * pose + c);
    }
    S_saved = S_(scalar, scalar);
    Grow(old_n + 6);
    S_(scalar, scalar) += D.topLeftCorner(6 * t, 6 * t);
    S_.block(0, old_n, old_n, 6).setZero();
    S_.block(old_n, 0, 6, old_n).setZero();
    S_(scalar, Eigen::seqN(old_n, 6)) = D.topRightCorner(6 * t, 6);
    S_(Eigen::seqN(old_n, 6), scalar) = D.bottomLeftCorner(6, 6 * t);
    S_.block<6, 6>(old_n, old_n) = D.bottomRightCorner<6, 6>();
    synced_poses_ = k + 1;
  }
  std::vector<std::pair<int, Feature>> saved;  // re-observed features as they were
  saved.reserve(observations.size());          // no reallocation between move-out and back
  const int old_features = static_cast<int>(features_.size());
  const size_t old_unsynced = unsynced_.size();
  std::vector<std::pair<int, int>> feature_order;  // (feature index, observation)
  for (size_t o = 0; o < observations.size(); ++o) {
    const SchurObservation& obs = observations[o];
    int index;
    if (obs.is_new) {
      index = static_cast<int>(features_.size());
      features_.emplace_back();
      features_.back().offset = obs.feature_offset;
      feature_of_offset_[obs.feature_offset] = index;
    } else {
      index = feature_of_offset_.at(obs.feature_offset);
      // Its fixed-size fields only: the update appends to its lists, and undoing it pops
      // them (copying them, tens to hundreds of couplings a feature, was wasted work).
      Feature& current = features_[index];
      std::vector<int> poses = std::move(current.poses);
      decltype(Feature::couplings) couplings = std::move(current.couplings);
      saved.emplace_back(index, current);
      current.poses = std::move(poses);
      current.couplings = std::move(couplings);
    }
    feature_order.emplace_back(index, static_cast<int>(o));
    Feature& feature = features_[index];
    feature.F += obs.I_ff;
    feature.F_inv = new_inverse[o];
    feature.log_det = 2.0 * feature.F.llt().matrixLLT().diagonal().array().log().sum();
    feature.poses.push_back(k);
    feature.couplings.push_back(obs.I_pf);
    if (!lazy) {
      feature.F_synced = feature.F;
      feature.F_inv_synced = feature.F_inv;
      feature.poses_synced = static_cast<int>(feature.poses.size());
    } else if (!feature.unsynced) {
      feature.unsynced = true;
      unsynced_.push_back(index);
    }
  }
  std::sort(feature_order.begin(), feature_order.end());
  for (const auto& [index, o] : feature_order) {
    pose_couplings_.push_back(observations[o].I_pf);
    pose_coupling_features_.push_back(index);
  }
  pose_coupling_ends_.push_back(static_cast<int>(pose_couplings_.size()));
  pose_offsets_.push_back(pose_offset);
  pose_of_offset_[pose_offset] = k;
  pose_blocks_.push_back(I_pp);
  num_couplings_ += static_cast<int64_t>(observations.size());
  const std::vector<int> saved_touched = last_touched_;
  for (const int pose : touched) last_touched_[pose] = updates_;
  last_touched_.push_back(updates_);
  ++updates_;

  bool ok = true;
  if (update == SchurUpdate::kDefer) {
    valid_ = false;
  } else if (!valid_) {
    ok = Refactor();
  } else if (lazy) {
    ok = PrepareLazyPreconditioner();  // false: S is not positive definite
    if (ok && choice != Choice::kLazy) {
      Sync();
      const Plan plan = PlanWindow(DirtyPoses());
      // Should both fail (S numerically indefinite), the lazy preconditioner stays.
      if (choice != Choice::kRenew || !RenewInSingle(plan.first, plan.order, plan.window_start)) {
        FactorFrom(plan.first, plan.order, plan.window_start, nullptr);
      }
    }
  } else {
    const Plan plan = PlanWindow(DirtyPoses());
    if (was_exact && plan.first == window_start_) {
      const Eigen::MatrixXd T = UpdatedWindow(plan, local, D);
      ok = FactorFrom(plan.first, plan.order, plan.window_start, &T);
    } else {
      ok = FactorFrom(plan.first, plan.order, plan.window_start, nullptr);
    }
  }
  if (ok) return true;

  // Not positive definite: undo.
  for (auto it = saved.rbegin(); it != saved.rend(); ++it) {
    Feature& feature = features_[it->first];
    it->second.poses = std::move(feature.poses);
    it->second.couplings = std::move(feature.couplings);
    it->second.poses.pop_back();
    it->second.couplings.pop_back();
    feature = std::move(it->second);
  }
  for (size_t u = old_unsynced; u < unsynced_.size(); ++u) {
    if (unsynced_[u] < old_features) features_[unsynced_[u]].unsynced = false;
  }
  unsynced_.resize(old_unsynced);
  for (const SchurObservation& obs : observations) {
    if (obs.is_new) feature_of_offset_.erase(obs.feature_offset);
  }
  features_.resize(old_features);
  pose_coupling_ends_.pop_back();
  const int old_couplings = k > 0 ? pose_coupling_ends_.back() : 0;
  pose_couplings_.resize(old_couplings);
  pose_coupling_features_.resize(old_couplings);
  pose_offsets_.pop_back();
  pose_blocks_.pop_back();
  num_couplings_ -= static_cast<int64_t>(observations.size());
  pose_of_offset_.erase(pose_offset);
  last_touched_ = saved_touched;
  --updates_;
  if (!lazy) {
    S_(scalar, scalar) = S_saved;
    synced_poses_ = k;
  }
  return false;
}

bool PoseSchurFactor::Refactor() {
  Sync();
  const int k = num_poses();
  std::vector<int> lead, window;
  for (int q = 0; q < k; ++q) {
    (last_touched_[q] + options_.evict_after <= updates_ ? lead : window).push_back(q);
  }
  std::vector<int> order = lead;
  order.insert(order.end(), window.begin(), window.end());
  return FactorFrom(0, order, static_cast<int>(lead.size()), nullptr);
}

bool PoseSchurFactor::MakeExact() {
  CHECK(valid_) << "no factor to make exact";
  if (exact()) return true;
  Sync();
  const Plan plan = PlanWindow(DirtyPoses());
  return FactorFrom(plan.first, plan.order, plan.window_start, nullptr);
}

std::vector<int> PoseSchurFactor::DirtyPoses() const {
  std::vector<int> dirty;
  for (int pose = 0; pose < static_cast<int>(order_.size()); ++pose) {
    if (last_touched_[pose] >= exact_since_update_) dirty.push_back(pose);
  }
  return dirty;
}

PoseSchurFactor::Plan PoseSchurFactor::PlanWindow(const std::vector<int>& touched) const {
  // Window positions: evicted poses first, then the ones kept, then anything moved in from
  // the leading part, then the poses not yet factored.
  const int k = static_cast<int>(order_.size());
  const int lead = window_start_;
  std::vector<int> evicted, kept;
  for (int q = lead; q < k; ++q) {
    const int pose = order_[q];
    (last_touched_[pose] + options_.evict_after <= updates_ ? evicted : kept).push_back(pose);
  }
  std::vector<char> move(k, 0);
  for (const int pose : touched) {
    if (position_[pose] >= lead) continue;
    for (int q = std::max(0, pose - options_.prefetch);
         q <= std::min(k - 1, pose + options_.prefetch); ++q) {
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

Eigen::MatrixXd PoseSchurFactor::UpdatedWindow(const Plan& plan, const std::vector<int>& local,
                                               const Eigen::MatrixXd& D) const {
  // The trailing block is C plus the change, in the new window order.
  const int k = static_cast<int>(order_.size());  // the new pose
  const int t = static_cast<int>(D.rows()) / 6 - 1;
  const int lead = window_start_;
  const std::vector<int>& order = plan.order;
  const int m = 6 * (k + 1 - lead);
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(m, m);
  // Rows of T and the rows of a source they take, for a map T row -> source row (-1: none).
  auto gather = [m](const std::vector<int>& source_row, std::vector<int>* rows,
                    std::vector<int>* source_rows) {
    for (int r = 0; r < m; ++r) {
      if (source_row[r] < 0) continue;
      rows->push_back(r);
      source_rows->push_back(source_row[r]);
    }
  };
  std::vector<int> from(m);  // new window row -> old C row (-1: the new pose)
  for (int q = lead; q <= k; ++q) {
    const int old_q = order[q] == k ? -1 : position_[order[q]] - lead;
    for (int c = 0; c < 6; ++c) from[6 * (q - lead) + c] = old_q < 0 ? -1 : 6 * old_q + c;
  }
  std::vector<int> rows, old_rows;
  gather(from, &rows, &old_rows);
  T(rows, rows) = C_(old_rows, old_rows);
  std::vector<int> d_rows(m);  // new window row -> row of D (-1: untouched)
  for (int q = lead; q <= k; ++q) {
    const int pose = order[q];
    const int l = pose == k ? t : local[pose];
    for (int c = 0; c < 6; ++c) d_rows[6 * (q - lead) + c] = l < 0 ? -1 : 6 * l + c;
  }
  std::vector<int> w_rows, dd_rows;
  gather(d_rows, &w_rows, &dd_rows);
  T(w_rows, w_rows) += D(dd_rows, dd_rows);
  return T;
}

bool PoseSchurFactor::FactorFrom(int first, const std::vector<int>& order, int window_start,
                                 const Eigen::MatrixXd* trailing) {
  // After a renewal in float only the leading columns it kept are exact: the order's prefix
  // up to `first` is the old one, so starting earlier changes nothing else.
  CHECK(trailing == nullptr || first <= double_columns_);
  first = std::min(first, double_columns_);
  const int n = dim();
  const int f6 = 6 * first, w6 = 6 * window_start;
  // The unchanged leading columns of L, rows moved to their new positions.
  const Eigen::MatrixXd L_lead =
      LeadingColumns(L_, first, f6, order, position_, static_cast<int>(order_.size()));
  Eigen::MatrixXd T;
  if (trailing != nullptr) {
    T = *trailing;
  } else {
    T = GatherLower<double>(S_, order, first);
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

  // Commit.
  Grow(n);
  L_.block(f6, 0, n - f6, f6) = L_lead;
  L_.block(f6, f6, a, a) = L11.triangularView<Eigen::Lower>();
  L_.block(w6, f6, m, a) = L21;
  L_.block(w6, w6, m, m) = L22.triangularView<Eigen::Lower>();
  C_ = std::move(C);
  double_columns_ = static_cast<int>(order.size());
  single_rows_ = std::min(single_rows_, first);
  Commit(order, window_start);
  return true;
}

bool PoseSchurFactor::RenewInSingle(int first, const std::vector<int>& order, int window_start) {
  SyncSingle();
  const int n = dim(), f6 = 6 * first;
  const int factored = static_cast<int>(order_.size());
  const int kept = std::min(first, double_columns_);
  const Eigen::MatrixXd lead = LeadingColumns(L_, first, 6 * kept, order, position_, factored);
  const Eigen::MatrixXf lead_single =
      LeadingColumns(L_single_, first, f6, order, position_, factored);
  Eigen::MatrixXf T = GatherLower<float>(S_, order, first);
  if (f6 > 0 && T.rows() > 0) T.selfadjointView<Eigen::Lower>().rankUpdate(lead_single, -1.0f);
  if (!FactorInPlace(&T)) return false;

  Grow(n);
  if (L_single_.size() == 0) L_single_.resize(L_.rows(), L_.cols());
  L_single_.block(f6, 0, n - f6, f6) = lead_single;
  L_single_.block(f6, f6, n - f6, n - f6) = T.triangularView<Eigen::Lower>();
  L_.block(f6, 0, n - f6, 6 * kept) = lead;
  double_columns_ = kept;
  single_rows_ = static_cast<int>(order.size());
  Commit(order, window_start);
  return true;
}

void PoseSchurFactor::SyncSingle() {
  const int factored = static_cast<int>(order_.size());
  if (single_rows_ >= factored) return;
  CHECK_EQ(double_columns_, factored) << "neither factor is up to date";
  const int n = 6 * factored, r6 = 6 * single_rows_;
  if (L_single_.rows() < L_.rows()) L_single_.conservativeResize(L_.rows(), L_.cols());
  L_single_.block(r6, 0, n - r6, n) = L_.block(r6, 0, n - r6, n).cast<float>();
  single_rows_ = factored;
}

void PoseSchurFactor::Commit(const std::vector<int>& order, int window_start) {
  order_ = order;
  position_.assign(order.size(), -1);
  for (int q = 0; q < static_cast<int>(order.size()); ++q) position_[order[q]] = q;
  window_start_ = window_start;
  valid_ = true;
  lazy_B_.resize(0, 0);
  exact_since_update_ = updates_;
  lazy_flops_ = 0.0;
  baseline_iterations_ = -1;
}

Eigen::VectorXd PoseSchurFactor::ReducedRhs(const Eigen::VectorXd& info_vector) const {
  Eigen::Matrix3Xd y(3, features_.size());  // F^-1 i_f
  for (size_t f = 0; f < features_.size(); ++f) {
    y.col(f) = features_[f].F_inv * info_vector.segment<3>(features_[f].offset);
  }
  Eigen::VectorXd b(dim());
  int e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    auto b_pose = b.segment<6>(6 * position_[pose]);
    b_pose = info_vector.segment<6>(pose_offsets_[pose]);
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      b_pose -= pose_couplings_[e] * y.col(pose_coupling_features_[e]);
    }
  }
  return b;
}

Eigen::VectorXd PoseSchurFactor::FullState(const Eigen::VectorXd& info_vector,
                                           const Eigen::VectorXd& x_p) const {
  Eigen::VectorXd x(info_vector.size());
  Eigen::Matrix3Xd r(3, features_.size());  // i_f - E_f x_p
  for (size_t f = 0; f < features_.size(); ++f) {
    r.col(f) = info_vector.segment<3>(features_[f].offset);
  }
  int e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    const auto x_pose = x_p.segment<6>(6 * position_[pose]);
    x.segment<6>(pose_offsets_[pose]) = x_pose;
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      r.col(pose_coupling_features_[e]) -= pose_couplings_[e].transpose() * x_pose;
    }
  }
  for (size_t f = 0; f < features_.size(); ++f) {
    x.segment<3>(features_[f].offset) = features_[f].F_inv * r.col(f);
  }
  return x;
}

Eigen::VectorXd PoseSchurFactor::Solve(const Eigen::VectorXd& info_vector) const {
  CHECK(exact()) << "no exact factor";
  Eigen::VectorXd x_p = ReducedRhs(info_vector);
  ApplyPreconditioner(/*single=*/false, &x_p);
  return FullState(info_vector, x_p);
}

double PoseSchurFactor::LogDet() const {
  CHECK(exact()) << "no exact factor";
  double sum = 0.0;
  for (const Feature& feature : features_) sum += feature.log_det;
  return sum + 2.0 * L_.topLeftCorner(dim(), dim()).diagonal().array().log().sum();
}

Eigen::MatrixXd PoseSchurFactor::InverseSubmatrix(const std::vector<int>& indices) const {
  CHECK(exact()) << "no exact factor";
  const int n = dim(), k = static_cast<int>(indices.size());
  // Each wanted scalar as (feature index or -1, component), and its column of R, the
  // pose-space right-hand side: the inverse restricted to `indices` is R^T S^-1 R plus the
  // features' own F^-1 blocks. first_row: the column's first row that may be nonzero.
  std::vector<std::pair<int, int>> feature_of(k, {-1, 0});
  std::vector<int> first_row(k, n);
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(n, k);
  for (int col = 0; col < k; ++col) {
    const int index = indices[col];
    bool found = false;
    for (int c = 0; c < 3 && !found; ++c) {
      const auto it = feature_of_offset_.find(index - c);
      if (it == feature_of_offset_.end()) continue;
      found = true;
      feature_of[col] = {it->second, c};
      const Feature& feature = features_[it->second];
      for (size_t e = 0; e < feature.poses.size(); ++e) {
        const int row = 6 * position_[feature.poses[e]];
        R.col(col).segment<6>(row) = -feature.couplings[e] * feature.F_inv.col(c);
        first_row[col] = std::min(first_row[col], row);
      }
    }
    for (int c = 0; c < 6 && !found; ++c) {
      const auto it = pose_of_offset_.find(index - c);
      if (it == pose_of_offset_.end()) continue;
      found = true;
      const int row = 6 * position_[it->second] + c;
      R(row, col) = 1.0;
      first_row[col] = row;
    }
    CHECK(found) << "state index " << index << " is neither a pose nor a feature";
  }
  // R^T S^-1 R = Z^T Z with Z = L^-1 R, and Z is zero above each column's first_row.
  // The columns, sorted by that row, are solved in groups, each from its group's first row
  // down: the features a buffer sees were first seen at very different times when the path
  // loops, and skipping the zero tops saves work (on the paper's simulation, buffer 3: the
  // single solve did 30-50% more flops; the recovery took 0.25-0.27 s instead of 0.31).
  // The products Z_a^T Z_b run over the rows where both can be nonzero.
  std::vector<int> sorted(k);
  for (int col = 0; col < k; ++col) sorted[col] = col;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [&](int a, int b) { return first_row[a] < first_row[b]; });
  constexpr int kGroupColumns = 48;  // wide enough for efficient blocked solves and products
  struct Group {
    std::vector<int> columns;
    int first = 0;
    Eigen::MatrixXd Z;  // rows first..n-1
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
  for (int a = 0; a < k; ++a) {
    for (int b = 0; b < k; ++b) {
      if (feature_of[a].first >= 0 && feature_of[a].first == feature_of[b].first) {
        result(a, b) +=
            features_[feature_of[a].first].F_inv(feature_of[a].second, feature_of[b].second);
      }
    }
  }
  return result;
}

int64_t PoseSchurFactor::FactorNonzeros() const {
  const int64_t n = dim();
  return n * (n + 1) / 2 + 6 * static_cast<int64_t>(features_.size());
}

}  // namespace ieslam
