// Dense alignment of the selected frames' range clouds, for the batch refinement.
//
// The filter and the bundle adjustment see a range image only through the few hundred
// features lifted from it. Its surfaces say much more about the relative pose of two frames
// that see the same part of the scene, from any distance in the sequence. Each pair of
// selected frames whose clouds overlap is aligned by point-to-plane ICP (projective data
// association, Gauss-Newton on SE(3), Huber-weighted, each point weighed by the range noise
// model). The aligned relative pose and the Gauss-Newton information of that alignment
// become a RelativePoseConstraint of the bundle adjustment, which then fits the features
// and all the pairs' surfaces together. Associations depend on the poses, so alignment and
// bundle adjustment alternate for a few rounds (multiway registration, as Choi, Zhou &
// Koltun, "Robust Reconstruction of Indoor Scenes", CVPR 2015, refine their fragments).
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "backend/bundle_adjustment.h"
#include "core/option_table.h"
#include "core/range_cloud.h"

namespace ieslam {

struct DepthAlignmentOptions {
  // Every n-th grid point of the source cloud in each direction is associated: with
  // RangeCloudOptions::step 4, one point per 16 range pixels. The information counts the
  // points as independent, but a Kinect's range errors are correlated over much more than
  // that: the constraints' variance factor (BundleAdjustmentOptions::weigh_relative_poses)
  // is 30-500 at one point per 8 pixels and a third to a quarter of that at one per 16, so
  // there more points add time and stated information, which the factor takes back, and
  // little else. The screen for overlapping pairs uses every other sample of this step.
  int sample_step = 4;
  // Later rounds halve the step down to this one where the first rounds' constraints prove
  // as precise as they state (SolveWithDepthAlignment): the points' errors independent, as on
  // a sensor that fits its noise model. Equal to sample_step: one step for every round.
  int dense_sample_step = 2;
  int max_iterations = 30;
  // Association gates on the point-to-point distance. The first phase allows for the error
  // of the starting relative pose (the front end's registrations are good to about a
  // centimetre); once that phase converges, the final gate keeps only points within the
  // range noise of far surfaces (Kinect v1 at 3.5 m: 2 cm) and so separates surfaces that
  // lie closer than the initial gate.
  double initial_gate_m = 0.05;
  double final_gate_m = 0.02;
  double max_normal_angle_deg = 30.0;
  // The four grid points a target surface is interpolated from must lie within this share
  // of their depth of each other (RangeCloud::Interpolate; as RangeCloudOptions' edge test).
  double max_depth_ratio = 0.05;
  // Huber weights on the point-to-plane residual in units of its noise.
  double huber_sigmas = 2.0;
  // A pair is aligned when at least min_overlap of the source's sampled points land on the
  // target's surfaces at the starting poses, and counts when as many have a partner at the
  // end, at least min_correspondences (a view has up to 1,200 samples at sample_step 4; 50
  // fix the six parameters several times over), and the robust spread of the whitened
  // residuals (1.4826 median |r| / sigma) is below max_robust_sigma: a wrong alignment leaves
  // surfaces apart and fails it. The share is low on purpose: the pairs that close loops
  // see the same surfaces from far apart and share little, and are the ones that remove
  // drift; a small overlap already carries only the information of its own points.
  double min_overlap = 0.1;
  int min_correspondences = 50;
  // Each frame picks at most this many others to be aligned with, spread over the sequence
  // (a pair is aligned when either frame picks it): the work and the bundle adjustment's
  // terms grow linearly with the frames, not quadratically.
  int max_partners = 20;
  double max_robust_sigma = 3.0;
  // Alternations of pairwise alignment and bundle adjustment; stops early once no pose
  // moves by more than convergence_m (at 1 m, also the rotation in radians). 0: no depth
  // alignment (the batch refinement is the bundle adjustment of the features alone).
  int rounds = 3;
  double convergence_m = 1e-3;
  // Rounds of rejections (BundleAdjustmentOptions::max_rejection_rounds; each also weighs
  // the pairs) in the bundle adjustment of a round before the last; -1: as many as the last
  // one; not 0, which would leave the pairs unweighed. Such a round only places the poses the
  // next round's pairs are aligned from, and the last round rejects again from every
  // observation. Two: the first round of rejections weighs the pairs at an optimum that
  // still holds the gross outliers, the second at one without them, and that variance
  // factor is where the next round's pairs start (it only grows); later rounds of rejections
  // move a few observations at the gate's edge. A round that ends the alternation early
  // (convergence_m) is solved again with every round of rejections.
  int early_rejection_rounds = 2;
  int num_threads = 1;  // pairs are aligned in parallel; the result does not depend on it

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<DepthAlignmentOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

struct PairAlignment {
  bool usable = false;
  std::string why_not;                                      // when not usable
  Eigen::Isometry3d T_t_s = Eigen::Isometry3d::Identity();  // target <- source sensor frame
  Matrix6d information = Matrix6d::Zero();                  // (omega, v), T = [Exp(omega), v] T_t_s
  int samples = 0;                                          // source points tried
  int correspondences = 0;
  double overlap = 0.0;  // correspondences / samples
  double robust_sigma = 0.0;
  int iterations = 0;
};

// How far `after` is from `before`: translation in metres or rotation in radians, whichever
// is larger (a pair's own start against the poses, a round's poses against the last's).
double PoseChange(const Eigen::Isometry3d& before, const Eigen::Isometry3d& after);

// Aligns `source` to `target` from the initial guess T_t_s (source sensor frame into the
// target's).
PairAlignment AlignRangeClouds(const RangeCloud& source, const RangeCloud& target,
                               const Eigen::Isometry3d& T_t_s_initial,
                               const DepthAlignmentOptions& options);

struct DepthAlignmentStats {
  int rounds = 0;
  int pairs_tried = 0;  // last round: pairs whose clouds overlap at the starting poses
  int constraints = 0;  // last round: pairs aligned and used
  int iterations = 0;   // last round: the Gauss-Newton steps of its pairs' alignments
  double mean_overlap = 0.0;
  // The constraints' information was divided by this in the solve that stands
  // (BundleAdjustmentOptions::weigh_relative_poses; 1 without).
  double variance_factor = 1.0;
  int sample_step = 0;             // the clouds' sampling in the solve that stands
  double seconds_alignment = 0.0;  // all rounds
  double seconds_screen = 0.0;     // of which finding the overlapping pairs
  double seconds_ba = 0.0;
};

// The constraints of every overlapping pair of clouds (frame ids of `clouds`) at the poses
// T_w_c, i < j; clouds without a pose are ignored. A pair with a constraint in `starts`
// (converged alignments, e.g. an earlier round's) within initial_gate_m of where T_w_c puts
// it is aligned from that constraint's T_sj_si in the final phase only, instead of from T_w_c
// through the coarse phase; the pairs tried are those T_w_c makes overlap either way, and
// within each run of a frame's partners (DepthAlignmentOptions::max_partners), a pair with
// such a start is kept over more overlapping ones.
std::vector<RelativePoseConstraint> AlignCloudPairs(
    const std::map<int, RangeCloud>& clouds, const std::map<int, Eigen::Isometry3d>& T_w_c,
    const DepthAlignmentOptions& options, DepthAlignmentStats* stats = nullptr,
    const std::vector<RelativePoseConstraint>* starts = nullptr);

// The bundle adjustment of `problem` with the clouds' pairwise constraints added
// (problem.relative_poses is replaced by them), alternated with the alignment for
// options.rounds rounds (0: the bundle adjustment of `problem` as it is). From the second
// round on, the pairs the last solve kept are aligned from their own last alignment
// (AlignCloudPairs' `starts`). A round before the last solves with
// options.early_rejection_rounds, and again with every rejection round when it ends the
// alternation after all. Only the solve whose result stands computes covariances. When a later
// round fails, the earlier result stands, solved again with every rejection round if it was
// solved with fewer; when one is interrupted, the earlier result stands as it was solved. In
// both cases, covariance_error says why covariances are missing.
BundleAdjustmentResult SolveWithDepthAlignment(BundleAdjustmentProblem problem,
                                               const PinholeCamera& camera,
                                               const std::map<int, RangeCloud>& clouds,
                                               const BundleAdjustmentOptions& ba_options,
                                               const DepthAlignmentOptions& options,
                                               DepthAlignmentStats* stats = nullptr);

}  // namespace ieslam
