// InformationFilter::Snapshot and Restore: the filter saved as its matrix, vector and state,
// and taken over by an empty filter.
#include <algorithm>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>

#include <glog/logging.h>

#include "backend/information_filter.h"
#include "core/error.h"

namespace ieslam {
namespace {

DataError BadSnapshot(const std::string& what) {
  return DataError("the saved filter does not hold together: " + what);
}

// The sizes, and that each column is upper triangular with its rows ascending.
void CheckShape(const FilterSnapshot& s) {
  const int n = s.dim;
  if (n <= 0 || static_cast<int>(s.column_starts.size()) != n + 1 ||
      s.information_vector.size() != n || s.state.size() != n) {
    throw BadSnapshot("dimension " + std::to_string(n) + " against " +
                      std::to_string(s.column_starts.size()) + " column starts, " +
                      std::to_string(s.information_vector.size()) + " information entries and " +
                      std::to_string(s.state.size()) + " state entries");
  }
  if (s.column_starts.front() != 0 || s.column_starts.back() != static_cast<int>(s.rows.size()) ||
      s.rows.size() != s.values.size()) {
    throw BadSnapshot("the column starts do not span the " + std::to_string(s.rows.size()) +
                      " entries");
  }
  for (int c = 0; c < n; ++c) {
    const int begin = s.column_starts[c], end = s.column_starts[c + 1];
    if (end <= begin || s.rows[end - 1] != c) {
      throw BadSnapshot("column " + std::to_string(c) + " does not end on its diagonal");
    }
    if (s.rows[begin] < 0) {
      throw BadSnapshot("column " + std::to_string(c) + " has the negative row " +
                        std::to_string(s.rows[begin]));
    }
    for (int k = begin + 1; k < end; ++k) {
      if (s.rows[k] <= s.rows[k - 1]) {
        throw BadSnapshot("the rows of column " + std::to_string(c) + " are not ascending");
      }
    }
  }
}

// Offset -> (is a pose, index into the snapshot's list), checked to tile the state as the
// filter lays it out: each pose's new features (3 each), then the pose (6), the last a pose.
std::map<int, std::pair<bool, int>> CheckLayout(const FilterSnapshot& s) {
  std::map<int, std::pair<bool, int>> variables;
  for (size_t k = 0; k < s.pose_offsets.size(); ++k) {
    if (!variables.emplace(s.pose_offsets[k].second, std::make_pair(true, static_cast<int>(k)))
             .second) {
      throw BadSnapshot("two variables at offset " + std::to_string(s.pose_offsets[k].second));
    }
  }
  for (size_t k = 0; k < s.feature_offsets.size(); ++k) {
    if (!variables.emplace(s.feature_offsets[k].second, std::make_pair(false, static_cast<int>(k)))
             .second) {
      throw BadSnapshot("two variables at offset " + std::to_string(s.feature_offsets[k].second));
    }
  }
  int next = 0, previous_pose = -1;
  bool last_is_pose = false;
  for (const auto& [offset, variable] : variables) {
    if (offset != next) {
      throw BadSnapshot("offset " + std::to_string(offset) + " where " + std::to_string(next) +
                        " was due");
    }
    if (variable.first && variable.second != previous_pose + 1) {
      throw BadSnapshot("the poses are not in the order of their offsets");
    }
    if (variable.first) previous_pose = variable.second;
    next += variable.first ? 6 : 3;
    last_is_pose = variable.first;
  }
  if (next != s.dim || !last_is_pose || s.pose_offsets.empty()) {
    throw BadSnapshot("the variables cover " + std::to_string(next) + " of dimension " +
                      std::to_string(s.dim) + ", or do not end with a pose");
  }
  return variables;
}

// The couplings of the feature at `feature` with the earlier poses that saw it before it
// entered (delayed initialisation): the pose rows of its columns. Their share of the poses'
// diagonal blocks is in those blocks already (the snapshot's are final), so none is added.
std::vector<EarlierSightingBlocks> EarlierSightings(const FilterSnapshot& s,
                                                    const std::vector<int>& pose_at, int feature) {
  std::map<int, Eigen::Matrix<double, 6, 3>> couplings;  // pose offset -> I_cf
  for (int j = 0; j < 3; ++j) {
    for (int k = s.column_starts[feature + j]; k < s.column_starts[feature + j + 1]; ++k) {
      const int row = s.rows[k];
      if (row >= feature) break;
      auto [it, added] = couplings.try_emplace(pose_at[row]);
      if (added) it->second.setZero();
      it->second(row - pose_at[row], j) = s.values[k];
    }
  }
  std::vector<EarlierSightingBlocks> earlier;
  for (const auto& [pose, I_cf] : couplings) {
    earlier.push_back({pose, Eigen::Matrix<double, 6, 6>::Zero(), I_cf});
  }
  return earlier;
}

// The update the pose at `offset` made, from its columns of `matrix` (filled up to that pose's
// last column): its diagonal block, its couplings, and the diagonal blocks of the features that
// entered with it (those from `pose_end`, where the pose before ended, to `offset`) with their
// couplings to earlier poses.
InformationUpdate PoseUpdate(const FilterSnapshot& s, const UpperColumnStorage& matrix,
                             const std::vector<int>& feature_at, const std::vector<int>& pose_at,
                             int offset, int pose_end) {
  InformationUpdate update;
  update.old_dim = pose_end;
  update.pose_block = matrix.DiagonalBlock(offset, 6);
  std::map<int, Eigen::Matrix<double, 6, 3>> couplings;
  for (int j = 0; j < 6; ++j) {
    for (int k = s.column_starts[offset + j]; k < s.column_starts[offset + j + 1]; ++k) {
      const int row = s.rows[k];
      if (row >= offset) break;
      auto [it, added] = couplings.try_emplace(feature_at[row]);
      if (added) it->second.setZero();
      it->second(j, row - feature_at[row]) = s.values[k];
    }
  }
  for (const auto& [feature, I_pf] : couplings) {
    const bool is_new = feature >= pose_end;
    update.observations.push_back(
        {feature, is_new,
         is_new ? Eigen::Matrix3d(matrix.DiagonalBlock(feature, 3)) : Eigen::Matrix3d::Zero(), I_pf,
         is_new ? EarlierSightings(s, pose_at, feature) : std::vector<EarlierSightingBlocks>()});
  }
  for (int f = pose_end; f < offset; f += 3) {
    if (couplings.count(f) == 0) {
      throw BadSnapshot("the feature at offset " + std::to_string(f) +
                        " is not observed by the pose it entered with");
    }
  }
  return update;
}

// The pending features by id, checked: each not in the state, seen at least once, its
// sightings from poses in the state and well formed.
std::map<int64_t, std::vector<FeatureSighting>> CheckPending(
    const FilterSnapshot& s, const std::unordered_map<int, int>& pose_offset,
    const std::unordered_map<int64_t, int>& feature_offset) {
  std::map<int64_t, std::vector<FeatureSighting>> pending;
  for (const PendingFeature& feature : s.pending) {
    const std::string name = "pending feature " + std::to_string(feature.id);
    if (feature.id < 0 || feature_offset.count(feature.id) > 0 ||
        !pending.emplace(feature.id, feature.sightings).second) {
      throw BadSnapshot(name + " has a negative id, is in the state or is there twice");
    }
    if (feature.sightings.empty()) throw BadSnapshot(name + " has no sighting");
    for (const FeatureSighting& sighting : feature.sightings) {
      if (pose_offset.count(sighting.frame_id) == 0) {
        throw BadSnapshot(name + " is seen by frame " + std::to_string(sighting.frame_id) +
                          ", which is no pose of the filter");
      }
      if (sighting.observation.feature_id != feature.id) {
        throw BadSnapshot(name + " has a sighting of feature " +
                          std::to_string(sighting.observation.feature_id));
      }
      const std::string problem = ObservationsProblem(sighting.frame_id, {sighting.observation});
      if (!problem.empty()) throw BadSnapshot(problem);
    }
  }
  return pending;
}

}  // namespace

FilterSnapshot InformationFilter::Snapshot() const {
  CheckRecovered();
  FilterSnapshot s;
  const auto upper = information_upper();
  s.dim = state_dim();
  s.column_starts.assign(upper.outerIndexPtr(), upper.outerIndexPtr() + s.dim + 1);
  s.rows.assign(upper.innerIndexPtr(), upper.innerIndexPtr() + upper.nonZeros());
  s.values.assign(upper.valuePtr(), upper.valuePtr() + upper.nonZeros());
  s.information_vector = info_vector_;
  s.state = state_;
  for (int frame : frame_ids_) s.pose_offsets.emplace_back(frame, pose_offset_.at(frame));
  for (int64_t id : feature_ids_) s.feature_offsets.emplace_back(id, feature_offset_.at(id));
  s.pending = PendingFeatures();
  return s;
}

void InformationFilter::Restore(const FilterSnapshot& s) {
  CHECK_EQ(state_dim(), 0) << "Restore is for an empty filter";
  CheckShape(s);
  const std::map<int, std::pair<bool, int>> variables = CheckLayout(s);
  std::unordered_map<int, int> pose_offset;
  std::unordered_map<int64_t, int> feature_offset;
  for (const auto& [frame, offset] : s.pose_offsets) {
    if (!pose_offset.emplace(frame, offset).second) {
      throw BadSnapshot("frame " + std::to_string(frame) + " is there twice");
    }
  }
  for (const auto& [id, offset] : s.feature_offsets) {
    if (!feature_offset.emplace(id, offset).second) {
      throw BadSnapshot("feature " + std::to_string(id) + " is there twice");
    }
  }
  // The feature holding each row of a pose's column, and the pose each row of a feature's
  // (a feature that entered on a later sighting couples with the poses that saw it before).
  std::vector<int> feature_at(s.dim, -1), pose_at(s.dim, -1);
  for (const auto& [offset, variable] : variables) {
    std::vector<int>& at = variable.first ? pose_at : feature_at;
    std::fill(at.begin() + offset, at.begin() + offset + (variable.first ? 6 : 3), offset);
  }
  std::map<int64_t, std::vector<FeatureSighting>> pending =
      CheckPending(s, pose_offset, feature_offset);
  // The matrix column by column; at each pose's last column the factor takes in the update
  // that pose made: its diagonal block, its couplings, and (all at once, as the new features
  // of that pose) the features' whole diagonal blocks, the sums the factor would have formed.
  // Built aside and swapped in only when all of it holds, so that a refusal leaves the filter
  // empty and ready for another snapshot.
  std::unique_ptr<InformationFactor> factor = NewFactor();
  UpperColumnStorage matrix;
  int pose_end = 0;
  for (const auto& [offset, variable] : variables) {
    const int width = variable.first ? 6 : 3;
    for (int c = offset; c < offset + width; ++c) {
      matrix.StartColumn();
      for (int k = s.column_starts[c]; k < s.column_starts[c + 1]; ++k) {
        const int row = s.rows[k];
        if (row < offset && (variable.first ? feature_at[row] : pose_at[row]) < 0) {
          throw BadSnapshot("column " + std::to_string(c) + " couples with row " +
                            std::to_string(row) + ", which a filter does not");
        }
        matrix.Append(row, s.values[k]);
      }
    }
    if (!variable.first) continue;
    factor->AddDeferred(matrix, PoseUpdate(s, matrix, feature_at, pose_at, offset, pose_end));
    pose_end = offset + 6;
  }
  if (!factor->Refactor(matrix)) {
    throw BadSnapshot("its information matrix is not positive definite");
  }
  factor_ = std::move(factor);
  matrix_ = std::move(matrix);
  info_vector_ = s.information_vector;
  state_ = s.state;
  pose_offset_ = std::move(pose_offset);
  feature_offset_ = std::move(feature_offset);
  for (const auto& frame_offset : s.pose_offsets) frame_ids_.push_back(frame_offset.first);
  restored_poses_ = static_cast<int>(frame_ids_.size());
  for (const auto& id_offset : s.feature_offsets) feature_ids_.push_back(id_offset.first);
  restored_features_ = static_cast<int>(feature_ids_.size());
  pending_ = std::move(pending);
  recovery_pending_ = false;
}

}  // namespace ieslam
