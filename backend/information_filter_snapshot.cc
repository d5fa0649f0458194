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

// The update the pose at `offset` made, from its columns of `matrix` (filled up to that pose's
// last column): its diagonal block, its couplings, and the diagonal blocks of the features that
// entered with it (those from `pose_end`, where the pose before ended, to `offset`).
InformationUpdate PoseUpdate(const FilterSnapshot& s, const UpperColumnStorage& matrix,
                             const std::vector<int>& feature_at, int offset, int pose_end) {
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
         is_new ? Eigen::Matrix3d(matrix.DiagonalBlock(feature, 3)) : Eigen::Matrix3d::Zero(),
         I_pf});
  }
  for (int f = pose_end; f < offset; f += 3) {
    if (couplings.count(f) == 0) {
      throw BadSnapshot("the feature at offset " + std::to_string(f) +
                        " is not observed by the pose it entered with");
    }
  }
  return update;
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
  // The feature holding each row of a pose's column.
  std::vector<int> feature_at(s.dim, -1);
  for (const auto& [offset, variable] : variables) {
    if (!variable.first)
      std::fill(feature_at.begin() + offset, feature_at.begin() + offset + 3, offset);
  }
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
        if (variable.first ? row < offset && feature_at[row] < 0 : row < offset) {
          throw BadSnapshot("column " + std::to_string(c) + " couples with row " +
                            std::to_string(row) + ", which a filter does not");
        }
        matrix.Append(row, s.values[k]);
      }
    }
    if (!variable.first) continue;
    factor->AddDeferred(matrix, PoseUpdate(s, matrix, feature_at, offset, pose_end));
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
  for (const auto& id_offset : s.feature_offsets) feature_ids_.push_back(id_offset.first);
  recovery_pending_ = false;
}

}  // namespace ieslam
