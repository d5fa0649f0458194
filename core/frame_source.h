// What the keyframe selector sees of a sequence: frames that can be registered against the
// base frames (those already in the filter), with their observations carrying global
// feature ids. The simulation (known data association) and the image front end (SIFT
// matching + RANSAC) both implement it, so Algorithm 1 is written once.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/observation.h"

namespace ieslam {

struct CandidateFrame {
  int frame = -1;
  double timestamp = 0.0;
  // Registered against a base frame. The first frame of a sequence has no base frame; its
  // T_base_c is its pose in the world (the origin of the map).
  bool registered = false;
  std::string reason;  // why not, when !registered
  int base_frame = -1;
  int common_features = 0;  // features shared with the base database
  Eigen::Isometry3d T_base_c = Eigen::Isometry3d::Identity();
  // Observations with global feature ids: features already in the map and new ones.
  std::vector<FeatureObservation> observations;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  virtual int size() const = 0;
  virtual double timestamp(int frame) const = 0;

  // The first frame: it defines the world frame (T_base_c = its pose in the world).
  virtual CandidateFrame PrepareFirst(int frame) = 0;
  // Matches `frame` against the base frames and registers it to the best-matching one.
  // Candidates prepared together see the same base frames; after a Commit, prepare again.
  virtual CandidateFrame Prepare(int frame) = 0;
  // Registers `frame` against one given base frame only (dead reckoning chains these).
  virtual CandidateFrame PrepareAgainst(int frame, int base_frame) = 0;
  // The candidate (as its last Prepare returned it) has entered the filter: its frame is a
  // base frame from now on and its new features are known.
  virtual void Commit(const CandidateFrame& candidate) = 0;
  // The caller will not prepare `frame` again, nor register against it (it is not a base
  // frame): the source may free what it keeps of it. Preparing it anyway still gives the same
  // candidate, from the frame processed anew.
  virtual void Release(int /*frame*/) {}
  // The selection is over: nothing is prepared, committed or released any more, and the
  // source may free everything it keeps (the base frames too).
  virtual void Finish() {}
};

}  // namespace ieslam
