// Screening of a frame's observations of map features before they enter the filter.
//
// Each (u, v, d) of a known feature is tested against its prediction from the map and the
// frame's other observations: the frame's pose is fitted to its observations of known
// features (robustly first, so that outliers do not drag it), and observation j is kept when
//   r_j^T C_j^-1 r_j <= gate_chi2,   C_j = Q_j + J_f P_f J_f^T - J_x P_x J_x^T,
// the chi-square (3 dof) test of its residual against the fit of the others (for a rejected
// one, whose residual is independent of the fit, + J_x P_x J_x^T). The kept set is then
// tested jointly with the features' joint covariance (joint compatibility, Neira & Tardos,
// IEEE T-RA 2001): single gates pass sets whose errors agree with one another but not with
// the map. A set that fails it first has its Q scaled by its variance factor (NIS per degree
// of freedom: the innovations' own estimate of the frame's noise, adapt_noise) and is gated
// again; then the worst observations are dropped until the set passes. With delayed
// initialisation a pending feature is a map feature here as well, through its first sighting
// (InformationFilter::JointFeatureCovariance): the gate then keeps what it would keep with
// every feature in the state. Observations of features no pose has seen have no prediction
// and pass untested (their Q is scaled with the frame's).
#pragma once

#include <vector>

#include "backend/information_filter.h"
#include "core/observation.h"
#include "core/pose.h"

namespace ieslam {

// Counts over one frame, or summed over a run.
struct GateStatistics {
  int frames = 0;
  int tested = 0;                    // observations of map features (known or pending)
  int rejected = 0;                  // by any test (single, joint, or not linearisable)
  int rejected_joint = 0;            // of `rejected`, by the joint test
  int incompatible_frames = 0;       // frames whose set still failed the joint test
  std::vector<double> noise_scales;  // each jointly tested frame's Q scale (1: as stated)

  void Add(const GateStatistics& other);
  double rejected_share() const { return tested > 0 ? double(rejected) / tested : 0.0; }
};

struct GatedObservations {
  std::vector<FeatureObservation> observations;  // the kept ones, in the input order
  // The pose fitted to the kept observations of known features (the initial pose when they
  // cannot determine it), a better linearisation point than a registration's.
  Vector6d T_w_c = Vector6d::Zero();
  bool pose_fitted = false;
  // The factor the kept observations' Q was scaled by (they carry the scaled Q).
  double noise_scale = 1.0;
  GateStatistics stats;
};

// Gates `observations` of a frame whose pose is near T_w_c_initial, with the filter's
// options (gate_chi2: 0 keeps every observation; joint_compatibility). `known` must cover
// every known feature observed (InformationFilter::JointFeatureCovariance); the pending ones
// it covers are tested too. `joint` false
// skips the joint test (for scoring many candidates).
GatedObservations GateObservations(const InformationFilter& filter, const Vector6d& T_w_c_initial,
                                   const std::vector<FeatureObservation>& observations,
                                   const FeatureCovariance& known, bool joint);

}  // namespace ieslam
