// Filter consistency measures (Bar-Shalom, Li & Kirubarajan, "Estimation with Applications
// to Tracking and Navigation", 2001, §5.4): the normalised estimation error squared (NEES)
// of a pose and the two-sided chi-square acceptance band of its average over Monte-Carlo
// runs.
#pragma once

#include <array>
#include <map>
#include <utility>
#include <vector>

#include "core/chi_square.h"
#include "core/pose.h"
#include "core/trajectory.h"

namespace ieslam {

// e^T P^-1 e with e = PoseDifference(estimate, truth) (angles wrapped).
double PoseNees(const Vector6d& estimate, const Vector6d& truth, const Matrix6d& covariance);

// The two-sided `confidence` band of the average NEES over `runs` runs of a `dim`-dimensional
// state: [chi2_{(1-c)/2}(dim*runs), chi2_{(1+c)/2}(dim*runs)] / runs.
std::pair<double, double> NeesBand(int dim, int runs, double confidence = 0.95);

// How well a set of stated pose covariances covers the poses' errors against ground truth:
// the paper's +-2 sigma plots (its Figs. 3-4) and the NEES, for one run on real data.
struct PoseConsistency {
  // Poses compared: with ground truth and a positive-definite covariance (an estimator's
  // fixed origin has neither uncertainty nor error, and is left out).
  int poses = 0;
  // Share of the position components (x, y, z of every pose) with |error| <= 2 sigma;
  // ~95% when the covariance is right and the errors Gaussian.
  double inside_2sigma = 0.0;
  // The same per component: x, y, z, alpha, beta, gamma.
  std::array<double, 6> inside_2sigma_per_axis{};
  // Median over the position components of |error| / sigma (~0.67 when right).
  double median_error_over_sigma = 0.0;
  // Mean over the poses of the 6-dof NEES, and the 95% band it falls in when the errors are
  // N(0, P) and independent from pose to pose. The errors of one run's poses are correlated
  // (they share the map), so this band is a yardstick, tighter than the truth: a mean NEES
  // far above it is overconfidence, one inside it does not prove consistency.
  double mean_nees = 0.0;
  std::pair<double, double> nees_band{0.0, 0.0};
  // The rotation free of the Euler angles' coupling (near-opposite alpha and gamma errors
  // can be a small rotation): the median angle of R_estimate R_truth^T, and the mean NEES of
  // that rotation vector against the covariance mapped onto it (3 dof) with its band.
  double median_rotation_error_deg = 0.0;
  double mean_rotation_nees = 0.0;
  std::pair<double, double> rotation_nees_band{0.0, 0.0};
  // Each pose compared, in frame order: error = PoseDifference(estimate, truth), the stated
  // sigmas (square roots of the covariance's diagonal) and the NEES.
  struct Pose {
    int frame = 0;
    Vector6d error = Vector6d::Zero();
    Vector6d sigma = Vector6d::Zero();
    double nees = 0.0;
    double rotation_error_deg = 0.0;
    double rotation_nees = 0.0;
  };
  std::vector<Pose> per_pose;
};

// `truth` in the estimate's frame (TruthInEstimateFrame); frames missing from `covariances`
// or `truth` are left out. `poses` == 0 when nothing could be compared.
PoseConsistency EvaluatePoseConsistency(const std::map<int, Vector6d>& estimates,
                                        const std::map<int, Matrix6d>& covariances,
                                        const std::map<int, Vector6d>& truth);

// The ground truth of the estimated frames, expressed in the estimate's frame by the frame
// every estimator here anchors, the first in time: truth_k = est_0 * gt_0^-1 * gt_k, gt
// interpolated at each frame's stamp (InterpolatePose within `max_gap_s`). No alignment is
// fitted: a fit would absorb the errors the covariances are meant to state. The anchor (its
// error zero by construction) and frames without ground truth are left out; empty when the
// anchor has none.
std::map<int, Vector6d> TruthInEstimateFrame(const Trajectory& ground_truth,
                                             const std::map<int, double>& timestamps,
                                             const std::map<int, Vector6d>& estimates,
                                             double max_gap_s);

}  // namespace ieslam
