#include "frontend/simulation/known_association_source.h"

#include <map>

#include <glog/logging.h>
#include <Eigen/Geometry>

namespace ieslam {

KnownAssociationSource::KnownAssociationSource(
    std::vector<std::vector<FeatureObservation>> observations, std::vector<double> timestamps,
    const PinholeCamera& camera, const Eigen::Isometry3d& T_w_first, int min_common_features)
    : observations_(std::move(observations)),
      timestamps_(std::move(timestamps)),
      camera_(camera),
      T_w_first_(T_w_first),
      min_common_features_(std::max(3, min_common_features)) {
  CHECK_EQ(observations_.size(), timestamps_.size());
}

Eigen::Vector3d KnownAssociationSource::Lift(const FeatureObservation& obs) const {
  return ObservationToWorld(Vector6d::Zero(), obs.z, camera_);
}

CandidateFrame KnownAssociationSource::PrepareFirst(int frame) {
  CandidateFrame candidate;
  candidate.frame = frame;
  candidate.timestamp = timestamp(frame);
  candidate.registered = true;
  candidate.T_base_c = T_w_first_;
  candidate.observations = observations_.at(frame);
  return candidate;
}

CandidateFrame KnownAssociationSource::Prepare(int frame) {
  CandidateFrame candidate;
  candidate.frame = frame;
  candidate.timestamp = timestamp(frame);
  candidate.observations = observations_.at(frame);
  // Shared features per base frame; std::map keeps the tie-break deterministic.
  std::map<int, int> shared;
  for (const FeatureObservation& obs : candidate.observations) {
    const auto it = sightings_.find(obs.feature_id);
    if (it == sightings_.end()) continue;
    ++candidate.common_features;
    for (const auto& [base, row] : it->second) ++shared[base];
  }
  int best = -1, best_count = 0;
  for (const auto& [base, count] : shared) {
    if (count >= best_count) {  // ties go to the most recent base frame
      best = base;
      best_count = count;
    }
  }
  if (best < 0) {
    candidate.reason = "shares no feature with the base frames";
    return candidate;
  }
  RegisterTo(best, &candidate);
  return candidate;
}

CandidateFrame KnownAssociationSource::PrepareAgainst(int frame, int base_frame) {
  CandidateFrame candidate;
  candidate.frame = frame;
  candidate.timestamp = timestamp(frame);
  candidate.observations = observations_.at(frame);
  RegisterTo(base_frame, &candidate);
  candidate.common_features = candidate.registered ? candidate.common_features : 0;
  return candidate;
}

void KnownAssociationSource::RegisterTo(int base, CandidateFrame* candidate) const {
  std::vector<Eigen::Vector3d> p_c, p_base;
  for (const FeatureObservation& obs : candidate->observations) {
    const auto it = sightings_.find(obs.feature_id);
    if (it == sightings_.end()) continue;
    for (const auto& [frame, row] : it->second) {
      if (frame != base) continue;
      p_c.push_back(Lift(obs));
      p_base.push_back(Lift(observations_[frame][row]));
    }
  }
  const int n = static_cast<int>(p_c.size());
  candidate->base_frame = base;
  if (n < min_common_features_) {
    candidate->reason = "shares " + std::to_string(n) + " features with base frame " +
                        std::to_string(base) + ", fewer than " +
                        std::to_string(min_common_features_);
    return;
  }
  const Eigen::Matrix3Xd src = Eigen::Map<const Eigen::Matrix3Xd>(p_c[0].data(), 3, n);
  const Eigen::Matrix3Xd dst = Eigen::Map<const Eigen::Matrix3Xd>(p_base[0].data(), 3, n);
  candidate->T_base_c.matrix() = Eigen::umeyama(src, dst, /*with_scaling=*/false);
  if (candidate->common_features == 0) candidate->common_features = n;
  candidate->registered = true;
}

void KnownAssociationSource::Commit(const CandidateFrame& candidate) {
  const std::vector<FeatureObservation>& observations = observations_.at(candidate.frame);
  for (int row = 0; row < static_cast<int>(observations.size()); ++row) {
    sightings_[observations[row].feature_id].emplace_back(candidate.frame, row);
  }
}

}  // namespace ieslam
