#include "backend/pose_schur_blocks.h"

#include <algorithm>
#include <utility>

#include <glog/logging.h>
#include <Eigen/Cholesky>

namespace ieslam {

namespace {

// F^-1 for a symmetric positive definite 3x3 F, exactly symmetric.
Eigen::Matrix3d SymmetricInverse(const Eigen::Matrix3d& F) {
  Eigen::Matrix3d inverse = F.llt().solve(Eigen::Matrix3d::Identity());
  return 0.5 * (inverse + inverse.transpose());
}

}  // namespace

void PoseSchurBlocks::Reserve(int capacity) {
  if (S_.rows() < capacity) S_.conservativeResize(capacity, capacity);
}

std::vector<int> PoseSchurBlocks::TouchedPoses(
    const std::vector<ObservationBlocks>& observations) const {
  std::vector<int> touched;
  for (const ObservationBlocks& obs : observations) {
    for (const EarlierSightingBlocks& earlier : obs.earlier) {
      const auto it = pose_of_offset_.find(earlier.pose_offset);
      CHECK(it != pose_of_offset_.end()) << "no pose at offset " << earlier.pose_offset;
      touched.push_back(it->second);
    }
    if (obs.is_new) continue;
    const auto it = feature_of_offset_.find(obs.feature_offset);
    CHECK(it != feature_of_offset_.end()) << "no feature at offset " << obs.feature_offset;
    const Feature& feature = features_[it->second];
    touched.insert(touched.end(), feature.poses.begin(), feature.poses.end());
  }
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  return touched;
}

PoseSchurBlocks::Change PoseSchurBlocks::ComputeChange(
    const Eigen::Matrix<double, 6, 6>& I_pp, const std::vector<ObservationBlocks>& observations,
    std::vector<int> touched, bool of_S) const {
  Change change;
  const int t = static_cast<int>(touched.size());
  change.local.assign(num_poses(), -1);
  for (int i = 0; i < t; ++i) change.local[touched[i]] = i;
  change.touched = std::move(touched);
  Eigen::MatrixXd& D = change.D;
  if (of_S) {
    D = Eigen::MatrixXd::Zero(6 * (t + 1), 6 * (t + 1));
    D.bottomRightCorner<6, 6>() = I_pp;
  }
  change.new_inverse.resize(observations.size());
  for (size_t o = 0; o < observations.size(); ++o) {
    const ObservationBlocks& obs = observations[o];
    const Matrix63& G = obs.I_pf;
    if (obs.is_new) {
      change.new_inverse[o] = SymmetricInverse(obs.I_ff);
      if (of_S) D.bottomRightCorner<6, 6>() -= G * change.new_inverse[o] * G.transpose();
      if (of_S && !obs.earlier.empty()) AddEarlierToChange(obs, change.new_inverse[o], &change);
      continue;
    }
    CHECK(obs.earlier.empty()) << "a known feature has no earlier sightings to add";
    const Feature& feature = features_[feature_of_offset_.at(obs.feature_offset)];
    const Eigen::Matrix3d F_inv_new = SymmetricInverse(feature.F + obs.I_ff);
    change.new_inverse[o] = F_inv_new;
    if (!of_S) continue;
    // F^-1 - F'^-1 = F^-1 A F'^-1 without the cancellation of the difference.
    Eigen::Matrix3d M = feature.F_inv * obs.I_ff * F_inv_new;
    M = 0.5 * (M + M.transpose());
    const int p = static_cast<int>(feature.poses.size());
    std::vector<Eigen::Matrix<double, 3, 6>> MBt(p);
    for (int a = 0; a < p; ++a) MBt[a] = M * feature.couplings[a].transpose();
    for (int a = 0; a < p; ++a) {
      const int la = change.local[feature.poses[a]];
      for (int b = 0; b < p; ++b) {
        const int lb = change.local[feature.poses[b]];
        if (lb < la) continue;
        D.block<6, 6>(6 * la, 6 * lb).noalias() += feature.couplings[a] * MBt[b];
      }
      D.block<6, 6>(6 * la, 6 * t).noalias() -= feature.couplings[a] * F_inv_new * G.transpose();
    }
    D.bottomRightCorner<6, 6>() -= G * F_inv_new * G.transpose();
  }
  if (of_S) D.triangularView<Eigen::StrictlyLower>() = D.transpose();
  return change;
}

void PoseSchurBlocks::AddEarlierToChange(const ObservationBlocks& obs, const Eigen::Matrix3d& F_inv,
                                         Change* change) const {
  // The feature's couplings are the earlier poses' I_cf and the new pose's I_pf: S loses
  // E^T F^-1 E over all of them, and the earlier poses' blocks gain their I_cc. Upper blocks
  // only (ComputeChange mirrors D).
  Eigen::MatrixXd& D = change->D;
  const int t = static_cast<int>(change->touched.size());
  for (const EarlierSightingBlocks& a : obs.earlier) {
    const int la = change->local[pose_of_offset_.at(a.pose_offset)];
    const Eigen::Matrix<double, 6, 3> EF = a.I_cf * F_inv;
    D.block<6, 6>(6 * la, 6 * la) += a.I_cc;
    for (const EarlierSightingBlocks& b : obs.earlier) {
      const int lb = change->local[pose_of_offset_.at(b.pose_offset)];
      if (lb < la) continue;
      D.block<6, 6>(6 * la, 6 * lb).noalias() -= EF * b.I_cf.transpose();
    }
    D.block<6, 6>(6 * la, 6 * t).noalias() -= EF * obs.I_pf.transpose();
  }
}

PoseSchurBlocks::Undo PoseSchurBlocks::AddPose(int pose_offset,
                                               const Eigen::Matrix<double, 6, 6>& I_pp,
                                               const std::vector<ObservationBlocks>& observations,
                                               const Change& change, bool update_S) {
  CHECK_EQ(pose_of_offset_.count(pose_offset), 0u) << "pose offset " << pose_offset << " taken";
  const int k = num_poses();
  Undo undo;
  undo.pose_offset = pose_offset;
  undo.old_features = num_features();
  undo.old_unsynced = unsynced_.size();
  undo.observations = static_cast<int64_t>(observations.size());
  if (update_S) AddToS(change, &undo);
  undo.saved.reserve(observations.size());
  std::vector<std::pair<int, int>> feature_order;  // (feature index, observation)
  for (size_t o = 0; o < observations.size(); ++o) {
    const int index = AddObservation(observations[o], change.new_inverse[o], update_S, &undo);
    feature_order.emplace_back(index, static_cast<int>(o));
    undo.observations += static_cast<int64_t>(observations[o].earlier.size());
  }
  AddEarlierSightings(observations, feature_order, update_S, &undo);
  std::sort(feature_order.begin(), feature_order.end());
  for (const auto& [index, o] : feature_order) {
    pose_couplings_.push_back(observations[o].I_pf);
    pose_coupling_features_.push_back(index);
  }
  pose_coupling_ends_.push_back(static_cast<int>(pose_couplings_.size()));
  pose_offsets_.push_back(pose_offset);
  pose_of_offset_[pose_offset] = k;
  pose_blocks_.push_back(I_pp);
  num_couplings_ += undo.observations;
  return undo;
}

void PoseSchurBlocks::AddToS(const Change& change, Undo* undo) {
  const int old_n = dim(), t = static_cast<int>(change.touched.size());
  const Eigen::MatrixXd& D = change.D;
  CHECK_EQ(synced_poses_, num_poses()) << "S must be synced before it is updated";
  CHECK_GE(S_.rows(), old_n + 6) << "no room in S for the new pose";
  for (const int pose : change.touched) {
    for (int c = 0; c < 6; ++c) undo->scalar.push_back(6 * pose + c);
  }
  const std::vector<int>& scalar = undo->scalar;
  undo->S_saved = S_(scalar, scalar);
  undo->updated_S = true;
  S_(scalar, scalar) += D.topLeftCorner(6 * t, 6 * t);
  S_.block(0, old_n, old_n, 6).setZero();
  S_.block(old_n, 0, 6, old_n).setZero();
  S_(scalar, Eigen::seqN(old_n, 6)) = D.topRightCorner(6 * t, 6);
  S_(Eigen::seqN(old_n, 6), scalar) = D.bottomLeftCorner(6, 6 * t);
  S_.block<6, 6>(old_n, old_n) = D.bottomRightCorner<6, 6>();
  synced_poses_ = num_poses() + 1;
}

int PoseSchurBlocks::AddObservation(const ObservationBlocks& obs,
                                    const Eigen::Matrix3d& new_inverse, bool update_S, Undo* undo) {
  int index;
  if (obs.is_new) {
    index = num_features();
    features_.emplace_back();
    features_.back().offset = obs.feature_offset;
    feature_of_offset_[obs.feature_offset] = index;
  } else {
    index = feature_of_offset_.at(obs.feature_offset);
    undo->saved.emplace_back(index, features_[index]);  // its values only
  }
  Feature& feature = features_[index];
  feature.F += obs.I_ff;
  feature.F_inv = new_inverse;
  feature.log_det = 2.0 * feature.F.llt().matrixLLT().diagonal().array().log().sum();
  for (const EarlierSightingBlocks& earlier : obs.earlier) {  // in pose order, before this one
    feature.poses.push_back(pose_of_offset_.at(earlier.pose_offset));
    feature.couplings.push_back(earlier.I_cf);
  }
  feature.poses.push_back(num_poses());
  feature.couplings.push_back(obs.I_pf);
  if (update_S) {
    feature.F_synced = feature.F;
    feature.F_inv_synced = feature.F_inv;
    feature.poses_synced = static_cast<int>(feature.poses.size());
  } else if (!feature.unsynced) {
    feature.unsynced = true;
    unsynced_.push_back(index);
  }
  return index;
}

void PoseSchurBlocks::AddEarlierSightings(const std::vector<ObservationBlocks>& observations,
                                          const std::vector<std::pair<int, int>>& feature_order,
                                          bool update_S, Undo* undo) {
  undo->old_pose_increments = unsynced_pose_increments_.size();
  struct Late {
    int pose, feature;
    const Matrix63* coupling;
  };
  std::vector<Late> late;
  for (const auto& [index, o] : feature_order) {
    for (const EarlierSightingBlocks& earlier : observations[o].earlier) {
      const int pose = pose_of_offset_.at(earlier.pose_offset);
      const bool saved = std::any_of(undo->saved_pose_blocks.begin(), undo->saved_pose_blocks.end(),
                                     [pose](const auto& p) { return p.first == pose; });
      if (!saved) undo->saved_pose_blocks.emplace_back(pose, pose_blocks_[pose]);
      pose_blocks_[pose] += earlier.I_cc;
      // An S that has this pose's block and was not given the change takes it at Sync.
      if (!update_S && pose < synced_poses_)
        unsynced_pose_increments_.emplace_back(pose, earlier.I_cc);
      late.push_back({pose, index, &earlier.I_cf});
    }
  }
  if (late.empty()) return;
  // Into the earlier poses' runs, after their couplings (the new features have the highest
  // indices, so each run stays in feature order): one pass over all couplings.
  std::stable_sort(late.begin(), late.end(), [](const Late& a, const Late& b) {
    return a.pose != b.pose ? a.pose < b.pose : a.feature < b.feature;
  });
  std::vector<Matrix63, Eigen::aligned_allocator<Matrix63>> couplings;
  std::vector<int> features, ends;
  couplings.reserve(pose_couplings_.size() + late.size());
  features.reserve(couplings.capacity());
  size_t l = 0;
  int e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      couplings.push_back(pose_couplings_[e]);
      features.push_back(pose_coupling_features_[e]);
    }
    for (; l < late.size() && late[l].pose == pose; ++l) {
      couplings.push_back(*late[l].coupling);
      features.push_back(late[l].feature);
    }
    ends.push_back(static_cast<int>(couplings.size()));
  }
  pose_couplings_.swap(couplings);
  pose_coupling_features_.swap(features);
  pose_coupling_ends_.swap(ends);
  undo->earlier_couplings = true;
}

void PoseSchurBlocks::DropCouplingsOfFeatures(int first_feature, int end_pose) {
  int kept = 0, e = 0;
  for (int pose = 0; pose < end_pose; ++pose) {
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      if (pose_coupling_features_[e] >= first_feature) continue;
      pose_couplings_[kept] = pose_couplings_[e];
      pose_coupling_features_[kept++] = pose_coupling_features_[e];
    }
    pose_coupling_ends_[pose] = kept;
  }
  pose_couplings_.resize(kept);
  pose_coupling_features_.resize(kept);
}

void PoseSchurBlocks::Revert(const Undo& undo) {
  for (auto it = undo.saved.rbegin(); it != undo.saved.rend(); ++it) {
    Feature& feature = features_[it->first];
    static_cast<FeatureValues&>(feature) = it->second;
    feature.poses.pop_back();
    feature.couplings.pop_back();
  }
  unsynced_.resize(undo.old_unsynced);
  for (int f = undo.old_features; f < num_features(); ++f) {
    feature_of_offset_.erase(features_[f].offset);
  }
  features_.resize(undo.old_features);
  pose_coupling_ends_.pop_back();
  const int old_couplings = pose_coupling_ends_.empty() ? 0 : pose_coupling_ends_.back();
  pose_couplings_.resize(old_couplings);
  pose_coupling_features_.resize(old_couplings);
  pose_offsets_.pop_back();
  pose_blocks_.pop_back();
  if (undo.earlier_couplings) DropCouplingsOfFeatures(undo.old_features, num_poses());
  for (auto it = undo.saved_pose_blocks.rbegin(); it != undo.saved_pose_blocks.rend(); ++it) {
    pose_blocks_[it->first] = it->second;
  }
  unsynced_pose_increments_.resize(undo.old_pose_increments);
  num_couplings_ -= undo.observations;
  pose_of_offset_.erase(undo.pose_offset);
  if (undo.updated_S) {
    S_(undo.scalar, undo.scalar) = undo.S_saved;
    synced_poses_ = num_poses();
  }
}

void PoseSchurBlocks::Sync() {
  const int k = num_poses(), synced = synced_poses_;
  if (synced == k && unsynced_.empty() && unsynced_pose_increments_.empty()) return;
  CHECK_GE(S_.rows(), 6 * k) << "no room in S for every pose";
  if (k > synced) {
    S_.block(6 * synced, 0, 6 * (k - synced), 6 * k).setZero();
    for (int pose = synced; pose < k; ++pose)
      S_.block<6, 6>(6 * pose, 6 * pose) = pose_blocks_[pose];
  }
  for (const auto& [pose, increment] : unsynced_pose_increments_) {
    S_.block<6, 6>(6 * pose, 6 * pose) += increment;
  }
  unsynced_pose_increments_.clear();
  // Pairs of poses that S has seen: F_synced^-1 - F^-1; pairs with a new pose: -F^-1.
  const int count = static_cast<int>(unsynced_.size());
  std::vector<Eigen::Matrix3d> M(count, Eigen::Matrix3d::Zero());
  std::vector<std::vector<std::pair<int, int>>> seen_by(k);  // pose -> (unsynced_ slot, e)
  for (int slot = 0; slot < count; ++slot) {
    const Feature& feature = features_[unsynced_[slot]];
    if (feature.poses_synced > 0) {
      M[slot] = feature.F_inv_synced * (feature.F - feature.F_synced) * feature.F_inv;
      M[slot] = 0.5 * (M[slot] + M[slot].transpose());
    }
    for (size_t e = 0; e < feature.poses.size(); ++e) {
      seen_by[feature.poses[e]].emplace_back(slot, static_cast<int>(e));
    }
  }
  // The blocks below the diagonal only (a feature's poses are increasing), a pose's columns
  // at a time: they stay in cache while every feature it saw adds to them (each block still
  // sums its features in the order of unsynced_).
  for (int pose = 0; pose < k; ++pose) {
    for (const auto& [slot, j] : seen_by[pose]) {
      const Feature& feature = features_[unsynced_[slot]];
      const int a = feature.poses_synced, p = static_cast<int>(feature.poses.size());
      const Eigen::Matrix<double, 3, 6> MBt = M[slot] * feature.couplings[j].transpose();
      const Eigen::Matrix<double, 3, 6> FBt = feature.F_inv * feature.couplings[j].transpose();
      for (int i = j; i < p; ++i) {
        Eigen::Matrix<double, 6, 6> block;
        if (i < a) {
          block.noalias() = feature.couplings[i] * MBt;
        } else {
          block.noalias() = -feature.couplings[i] * FBt;
        }
        S_.block<6, 6>(6 * feature.poses[i], 6 * pose) += block;
      }
    }
  }
  for (const int index : unsynced_) {
    Feature& feature = features_[index];
    feature.F_synced = feature.F;
    feature.F_inv_synced = feature.F_inv;
    feature.poses_synced = static_cast<int>(feature.poses.size());
    feature.unsynced = false;
  }
  unsynced_.clear();
  synced_poses_ = k;
}

Eigen::VectorXd PoseSchurBlocks::ReducedRhs(const Eigen::VectorXd& info_vector,
                                            const std::vector<int>& position) const {
  Eigen::Matrix3Xd y(3, features_.size());  // F^-1 i_f
  for (size_t f = 0; f < features_.size(); ++f) {
    y.col(f) = features_[f].F_inv * info_vector.segment<3>(features_[f].offset);
  }
  Eigen::VectorXd b(dim());
  int e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    auto b_pose = b.segment<6>(6 * position[pose]);
    b_pose = info_vector.segment<6>(pose_offsets_[pose]);
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      b_pose -= pose_couplings_[e] * y.col(pose_coupling_features_[e]);
    }
  }
  return b;
}

Eigen::VectorXd PoseSchurBlocks::FullState(const Eigen::VectorXd& info_vector,
                                           const Eigen::VectorXd& x_p,
                                           const std::vector<int>& position) const {
  Eigen::VectorXd x(info_vector.size());
  Eigen::Matrix3Xd r(3, features_.size());  // i_f - E_f x_p
  for (size_t f = 0; f < features_.size(); ++f) {
    r.col(f) = info_vector.segment<3>(features_[f].offset);
  }
  int e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    const auto x_pose = x_p.segment<6>(6 * position[pose]);
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

void PoseSchurBlocks::MultiplyS(const Eigen::VectorXd& x, const std::vector<int>& position,
                                Eigen::VectorXd* y) const {
  // u_f = E_f x, then y = I_pp x - E^T F^-1 u, pose by pose.
  Eigen::Matrix3Xd u = Eigen::Matrix3Xd::Zero(3, features_.size());
  int e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    const auto x_pose = x.segment<6>(6 * position[pose]);
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      u.col(pose_coupling_features_[e]).noalias() += pose_couplings_[e].transpose() * x_pose;
    }
  }
  for (size_t f = 0; f < features_.size(); ++f) {
    const Eigen::Vector3d v = features_[f].F_inv * u.col(f);
    u.col(f) = v;
  }
  y->resize(dim());
  e = 0;
  for (int pose = 0; pose < num_poses(); ++pose) {
    const int row = 6 * position[pose];
    auto y_pose = y->segment<6>(row);
    y_pose.noalias() = pose_blocks_[pose] * x.segment<6>(row);
    for (const int end = pose_coupling_ends_[pose]; e < end; ++e) {
      y_pose.noalias() -= pose_couplings_[e] * u.col(pose_coupling_features_[e]);
    }
  }
}

void PoseSchurBlocks::SchurBlocksOfPoses(int first_pose, const std::vector<int>& position,
                                         Eigen::MatrixXd* C_out, Eigen::MatrixXd* B_out) const {
  const int factored = first_pose;
  const int old_n = 6 * factored, lazy_n = dim() - old_n;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(lazy_n, lazy_n);
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(old_n, lazy_n);
  for (int pose = factored; pose < num_poses(); ++pose) {
    C.block<6, 6>(6 * (pose - factored), 6 * (pose - factored)) = pose_blocks_[pose];
  }
  // The features the later poses saw, in index order.
  const int first_later = factored > 0 ? pose_coupling_ends_[factored - 1] : 0;
  std::vector<int> seen(pose_coupling_features_.begin() + first_later,
                        pose_coupling_features_.end());
  std::sort(seen.begin(), seen.end());
  seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
  for (const int index : seen) {
    const Feature& feature = features_[index];
    const int p = static_cast<int>(feature.poses.size());
    // Poses are appended in order: the later poses' observations come last.
    for (int e = p - 1; e >= 0 && feature.poses[e] >= factored; --e) {
      const Eigen::Matrix<double, 3, 6> V = feature.F_inv * feature.couplings[e].transpose();
      const int col = 6 * (feature.poses[e] - factored);
      for (int i = 0; i < p; ++i) {
        const int pose = feature.poses[i];
        if (pose >= factored) {
          C.block<6, 6>(6 * (pose - factored), col).noalias() -= feature.couplings[i] * V;
        } else {
          B.block<6, 6>(6 * position[pose], col).noalias() -= feature.couplings[i] * V;
        }
      }
    }
  }
  *C_out = std::move(C);
  *B_out = std::move(B);
}

double PoseSchurBlocks::FeatureLogDet() const {
  double sum = 0.0;
  for (const Feature& feature : features_) sum += feature.log_det;
  return sum;
}

PoseSchurBlocks::InverseColumns PoseSchurBlocks::ColumnsOf(const std::vector<int>& indices,
                                                           const std::vector<int>& position) const {
  const int n = dim(), k = static_cast<int>(indices.size());
  InverseColumns columns;
  columns.feature_of.assign(k, {-1, 0});
  columns.first_row.assign(k, n);
  columns.R = Eigen::MatrixXd::Zero(n, k);
  for (int col = 0; col < k; ++col) {
    const int index = indices[col];
    bool found = false;
    for (int c = 0; c < 3 && !found; ++c) {
      const auto it = feature_of_offset_.find(index - c);
      if (it == feature_of_offset_.end()) continue;
      found = true;
      columns.feature_of[col] = {it->second, c};
      const Feature& feature = features_[it->second];
      for (size_t e = 0; e < feature.poses.size(); ++e) {
        const int row = 6 * position[feature.poses[e]];
        columns.R.col(col).segment<6>(row) = -feature.couplings[e] * feature.F_inv.col(c);
        columns.first_row[col] = std::min(columns.first_row[col], row);
      }
    }
    for (int c = 0; c < 6 && !found; ++c) {
      const auto it = pose_of_offset_.find(index - c);
      if (it == pose_of_offset_.end()) continue;
      found = true;
      const int row = 6 * position[it->second] + c;
      columns.R(row, col) = 1.0;
      columns.first_row[col] = row;
    }
    CHECK(found) << "state index " << index << " is neither a pose nor a feature";
  }
  return columns;
}

void PoseSchurBlocks::AddFeatureInverses(const InverseColumns& columns,
                                         Eigen::MatrixXd* inverse) const {
  const std::vector<std::pair<int, int>>& feature_of = columns.feature_of;
  const int k = static_cast<int>(feature_of.size());
  for (int a = 0; a < k; ++a) {
    for (int b = 0; b < k; ++b) {
      if (feature_of[a].first >= 0 && feature_of[a].first == feature_of[b].first) {
        (*inverse)(a, b) +=
            features_[feature_of[a].first].F_inv(feature_of[a].second, feature_of[b].second);
      }
    }
  }
}

}  // namespace ieslam
