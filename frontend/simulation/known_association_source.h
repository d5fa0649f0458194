// A FrameSource for sequences whose data association is known (the paper's simulation):
// observations already carry global feature ids (the filter decides when a feature enters its
// state: at once, or with delayed initialisation at its second sighting). A candidate is registered
// to the base frame it shares most features with, by a closed-form rigid fit (Eigen's Umeyama, no
// scale) of the two frames' lifted observations of the shared features.
#pragma once

#include <unordered_map>
#include <vector>

#include "core/camera.h"
#include "core/frame_source.h"

namespace ieslam {

class KnownAssociationSource : public FrameSource {
 public:
  // observations[k] are frame k's; T_w_first is the first frame's pose in the world.
  KnownAssociationSource(std::vector<std::vector<FeatureObservation>> observations,
                         std::vector<double> timestamps, const PinholeCamera& camera,
                         const Eigen::Isometry3d& T_w_first, int min_common_features = 3);

  int size() const override { return static_cast<int>(observations_.size()); }
  double timestamp(int frame) const override { return timestamps_.at(frame); }
  CandidateFrame PrepareFirst(int frame) override;
  CandidateFrame Prepare(int frame) override;
  CandidateFrame PrepareAgainst(int frame, int base_frame) override;
  void Commit(const CandidateFrame& candidate) override;

 private:
  // Registers the candidate to `base` by the features they share.
  void RegisterTo(int base, CandidateFrame* candidate) const;
  // The observation's point in its camera's frame.
  Eigen::Vector3d Lift(const FeatureObservation& obs) const;

  std::vector<std::vector<FeatureObservation>> observations_;
  std::vector<double> timestamps_;
  PinholeCamera camera_;
  Eigen::Isometry3d T_w_first_;
  int min_common_features_;
  // For each known feature, the base frames that observed it and the row of the observation.
  std::unordered_map<int64_t, std::vector<std::pair<int, int>>> sightings_;
};

}  // namespace ieslam
