// A Ceres bundle adjustment over the selected poses and 3-D features: the smoothing
// reference that the filter is checked against, and a batch refinement.
//
// It minimises 1/2 sum_k |W_k (h(T_w_c, p_w) - z_k)|^2 with the filter's own (u, v, d) model
// and the filter's own Q_k (W_k^T W_k = Q_k^-1; backend/ba_residuals.h), so that with the
// same observations both estimators solve the same problem; the filter linearises each
// observation once, the bundle adjustment iterates to the maximum a posteriori estimate.
//
// Rotations are unit quaternions on ceres::EigenQuaternionManifold. The gauge is fixed as the
// filter fixes it: the anchor pose (the first pose) is held constant.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "backend/pose_covariance.h"
#include "core/camera.h"
#include "core/observation.h"
#include "core/option_table.h"
#include "core/pose.h"

namespace ieslam {

class InformationFilter;

enum class BaRobustLoss { kNone, kHuber };
enum class BaLinearSolver { kAuto, kDenseSchur, kSparseSchur, kSparseNormalCholesky };

std::string BaRobustLossName(BaRobustLoss loss);  // "none", "huber"
// The loss named `name` (as BaRobustLossName writes it); false for any other name.
bool ParseBaRobustLoss(const std::string& name, BaRobustLoss* loss);
std::string BaLinearSolverName(BaLinearSolver solver);  // "auto", "dense_schur", ...
std::string BaCovarianceName(BaCovariance method);      // "schur", "sparse_qr"

// BaLinearSolver::kAuto factors the reduced camera system densely (Eigen) when it has at most
// kDenseSchurMaxPoses free poses and either at most kDenseSchurAlwaysPoses or at least
// kDenseSchurMinDensity of its off-diagonal pose blocks filled (two poses share a feature or a
// relative pose), and sparsely (CHOLMOD) otherwise. A room seen over and over fills the system
// nearly completely, and a nearly full system costs a sparse factorisation the dense flops
// plus its bookkeeping (Ceres assembles it cell by cell in a hash map): the dense solve is then
// faster. A long path through new places leaves it sparse, where CHOLMOD's fill-reducing order
// wins. The cap keeps the dense matrix (36 n^2 doubles) under ~650 MB.
constexpr int kDenseSchurAlwaysPoses = 200;
constexpr int kDenseSchurMaxPoses = 1500;
constexpr double kDenseSchurMinDensity = 0.2;

struct BundleAdjustmentResult;

struct BundleAdjustmentOptions {
  int max_iterations = 100;
  // A solve stops after a successful step that lowered the cost by less than this, in the
  // cost's own units (1/2 chi-square). Near the optimum the cost exceeds its minimum by
  // 1/2 dx^T H dx and Levenberg-Marquardt's steps shrink geometrically, so a step that
  // gains 0.005 leaves the estimate about sqrt(2 * 0.005) = 0.1 sigma (Mahalanobis, in all
  // parameters together) from the optimum: far below the noise the result is judged by,
  // whatever the problem's size. A relative tolerance alone stops later the larger the
  // problem (its cost grows with the observations). A solve started as Gauss-Newton (below)
  // also stops after an undamped step whose gain the linear model predicted to within this:
  // near the optimum the next step gains about what the model missed, so it would stop
  // there, one linear solve later, at about the same point. 0: only the tolerances below.
  double cost_tolerance = 0.005;
  // Relative cost decrease below which Levenberg-Marquardt stops. Tighter than Ceres'
  // default (1e-6) because the result is a reference for the filter, not a quick fix.
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;
  double parameter_tolerance = 1e-10;
  // Levenberg-Marquardt's first trust region; its reciprocal is the first damping, relative
  // to the Jacobi-scaled diagonal of J^T J. Every solve here starts near its optimum (the
  // filter's estimate, or the last solve after a round of rejections), where Gauss-Newton
  // converges in a step or two; damping at Ceres' default (1e4) holds back the weakly
  // observed directions, whose eigenvalues lie far below the diagonal, so the cost then
  // falls by a few times per step instead. A step that does not lower the cost, or that the
  // linear solver cannot take, shrinks the region (by 2, 4, 8, ...: below Ceres' default
  // after five such steps; ten in a row end the solve). From 1e-32 to 1e16.
  double initial_trust_region_radius = 1e8;
  // Huber on the whitened residual norm: quadratic up to `huber_scale` sigmas.
  BaRobustLoss robust_loss = BaRobustLoss::kNone;
  double huber_scale = 2.0;
  // Observations whose squared whitened residual |W (h - z)|^2 exceeds this at the optimum
  // are dropped and the problem solved again from there, until none is (at most
  // max_rejection_rounds times). 16.27 is chi-square with 3 degrees of freedom at 1 - 1e-3:
  // a true observation fails it once in a thousand. When the median squared residual says
  // Q understates the noise, the gate widens by that factor (never narrows). The front
  // end's 3-D RANSAC threshold is sized for the range noise and isotropic, so it lets
  // through wrong associations off by several centimetres across the ray (tens of pixels),
  // few but carrying much of the cost, and the least-squares optimum follows them
  // (docs/filter_internals.md). 0: keep every observation (the filter's exact problem).
  double rejection_chi2 = 16.27;
  int max_rejection_rounds = 5;
  // Relative poses weighed by their own variance factor: after each solve, with each round of
  // rejections (also when rejection_chi2 is 0, within max_rejection_rounds), their
  // information is divided by the median of their squared whitened residuals over
  // chi-square(6)'s median (>= 1, as the gate's widening: never more precise than stated), and
  // the problem is solved again when that moved the weight by more than 5%. A dense alignment's
  // information counts its thousands of points as independent; a range imager's errors are
  // correlated within a frame (depth distortion, calibration, timing), and the constraints' own
  // spread about the joint optimum says by how much. Where the information is right the factor
  // is 1.
  bool weigh_relative_poses = true;
  // Read by the batch refinement (selection/pipeline/refinement.h), not by the solver: the
  // refinement solves with every registered observation at its stated Q
  // (BundleAdjustmentProblem::registered), left to the rejection rounds above, rather than
  // with what the filter's gate took. The gate judges each frame online against the map's
  // stated covariance, which on real data is too small, and refuses right measurements with
  // the wrong ones; the batch judges them all at its own optimum. The bundle adjustment the
  // filter is checked against keeps the filter's information.
  bool refine_registered = true;
  // Read by the batch refinement, not by the solver: after the bundle adjustment the filter is
  // checked against, the range imager's depth correction is estimated from that adjustment's
  // observations (backend/depth_correction.h) and reported, with a calibration that applies it
  // for the next run. The refinement's own solves keep the depth as it was read (but see
  // apply_depth_correction).
  bool estimate_depth_correction = false;
  // Read by the batch refinement too (needs estimate_depth_correction): with a usable estimate
  // that a calibration allows, the refinement is made again, every range of the observations
  // and the clouds divided by the estimate's factor, and that is the refinement (one-pass
  // self-calibration).
  bool apply_depth_correction = false;
  // With the Schur solvers the features are eliminated first and the reduced camera system
  // of the poses is factored, densely (Eigen) or sparsely (SuiteSparse/CHOLMOD);
  // sparse_normal_cholesky factors the whole normal equations with CHOLMOD. auto: dense
  // or sparse Schur by the reduced system's size and fill (kDenseSchurMaxPoses).
  BaLinearSolver linear_solver = BaLinearSolver::kAuto;
  // 1: the same input gives bit-identical output.
  int num_threads = 1;
  // Per-pose 6x6 marginal covariances of the last solve, from the Gauss-Newton information
  // J^T J at the solution (the loss applied).
  bool compute_covariances = true;
  // How (backend/pose_covariance.h).
  BaCovariance covariance_method = BaCovariance::kSchur;
  // An observation whose point is closer than this to the camera plane is invalid.
  double min_depth_m = 1e-3;
  // Polled before each solve and after each iteration (not an option: no key, not reported):
  // true ends the solve there, the result then `interrupted`.
  std::function<bool()> stop;
  // With compute_covariances, asked once after the last solve with the result as it is
  // returned (poses, features, rejections, the relative poses' weight), when that solve is
  // usable, not interrupted and observes a frame: false leaves the covariances out (not an
  // option: no key). A caller that solves again from the result and keeps only the last
  // uses it.
  std::function<bool(const BundleAdjustmentResult&)> covariances_wanted;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<BundleAdjustmentOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

// One observation: frame `frame_id` saw feature observation.feature_id as observation.z.
struct BundleAdjustmentObservation {
  int frame_id = -1;
  FeatureObservation observation;
};

// A measured relative pose between the sensors of two frames (e.g. two range imagers'
// clouds aligned by backend/depth_alignment.h): with T_c_s the sensor's pose in the colour
// camera and T_w_c the frames' poses, Y = (T_w_cj T_c_s)^-1 T_w_ci T_c_s maps frame i's
// sensor coordinates into frame j's, and the measurement says Y = [Exp(omega), v] T_sj_si
// with (omega, v) ~ N(0, H^-1), H = S^T S. Residual: S (Log(R_E), t_E) for E = Y T_sj_si^-1
// (backend/ba_residuals.h). H may be singular: a direction the measurement does not
// determine (a plane slides in its own directions) carries no information.
struct RelativePoseConstraint {
  int frame_i = -1;
  int frame_j = -1;
  Eigen::Isometry3d T_sj_si = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_c_s = Eigen::Isometry3d::Identity();
  Matrix6d sqrt_information = Matrix6d::Zero();  // S; rotation (omega) first, then v
};

// The initial estimate and the observations. A plain value, filled by the caller (e.g. from
// the filter's estimate and the observations that went into it, MakeProblemFromFilter).
struct BundleAdjustmentProblem {
  std::map<int, Eigen::Isometry3d> T_w_c;  // by frame id
  std::map<int64_t, Eigen::Vector3d> p_w;  // by feature id
  std::vector<BundleAdjustmentObservation> observations;
  // Where the filter's observation gate took the registered observations otherwise (refused
  // some, scaled the Q of others): every registered observation of the problem's poses and
  // features with its stated Q; else empty. SolveBundleAdjustment uses `observations` only
  // (the filter's own information, which the smoother is checked against); a refinement may
  // solve with these instead.
  std::vector<BundleAdjustmentObservation> registered;
  // Terms between poses besides the observations; none in the filter's own problem.
  std::vector<RelativePoseConstraint> relative_poses;
  // The pose held fixed (the gauge); -1: the smallest frame id.
  int anchor_frame_id = -1;

  int AnchorFrameId() const;  // CHECK-fails on a problem without poses
};

// The filter's current estimate as the initial value, anchored at the filter's first pose,
// with the observations of `observations_by_frame` made from frames the filter holds (others
// are skipped: they were not selected) of features in its state (sightings of pending
// features, seen by too few poses to enter it, are skipped too: a feature seen from one pose
// constrains none). Throws DataError naming the frame and the feature when an observation of
// a selected frame refers to a feature the filter does not know. With `registered_by_frame`
// (the frames whose observations the gate took otherwise, as registered) `registered` holds
// every selected frame's observations under the same rules: a frame's entry there where it
// has one, else its filter's observations (a frame the gate left alone, or one a continued
// run's map brought, which keeps only what the filter took).
BundleAdjustmentProblem MakeProblemFromFilter(
    const InformationFilter& filter,
    const std::map<int, std::vector<FeatureObservation>>& observations_by_frame,
    const std::map<int, std::vector<FeatureObservation>>& registered_by_frame = {});

// `problem` started from other poses: T_w_c (which must hold every frame of the problem;
// DataError naming the first missing one otherwise) replaces its poses, and each feature is
// placed at the per-axis median of its observations back-projected from them, so that the
// start owes nothing to the estimate the problem was made from. The median keeps an
// outlying observation from moving a feature; the bundle adjustment's gate rejects it.
// What `ieslam refine --from-ground-truth` solves: where the data's own optimum lies when
// started at the ground truth.
BundleAdjustmentProblem WithPoses(const BundleAdjustmentProblem& problem,
                                  const std::map<int, Eigen::Isometry3d>& T_w_c,
                                  const PinholeCamera& camera);

struct BundleAdjustmentResult {
  std::map<int, Eigen::Isometry3d> T_w_c;
  std::map<int, Vector6d> poses;  // the paper's (x, y, z, alpha, beta, gamma), IsometryToPose
  std::map<int64_t, Eigen::Vector3d> p_w;
  // When options.compute_covariances (and covariances_wanted agrees): per pose, the
  // covariance of (dt, phi) with t_true = t + dt and R_true = Exp(phi) R (phi a rotation
  // vector in the world frame), translation first. The anchor's is zero.
  std::map<int, Matrix6d> pose_covariances;
  // The same, carried to the paper's Euler 6-vector (as the filter's PoseCovariance) by the
  // Jacobian of (alpha, beta, gamma) with respect to phi; NaN at gimbal lock.
  std::map<int, Matrix6d> pose_covariances_euler;
  // Empty when the covariances were computed or not asked for; else why they are missing
  // (e.g. a rank-deficient Jacobian: a pose or feature the observations do not determine).
  std::string covariance_error;

  int observations = 0;  // the problem's observations, kept and rejected
  // Observations dropped by the rejection_chi2 gate, in the order of problem.observations,
  // and the gate's last variance factor (>= 1: the gate was rejection_chi2 times this).
  std::vector<BundleAdjustmentObservation> rejected;
  double rejection_variance_factor = 1.0;
  // Relative poses dropped by the same gate at the same probability for 6 degrees of freedom
  // (22.46 for rejection_chi2 16.27), widened by their own variance factor; and per
  // problem.relative_poses entry, whether the last solve kept it (empty when none ran).
  int rejected_relative_poses = 0;
  std::vector<char> relative_pose_kept;
  // The relative poses' information was divided by this in the last solve that ran
  // (weigh_relative_poses; 1 without).
  double relative_pose_variance_factor = 1.0;

  // The noise model checked without ground truth: each observation's error h - z at the
  // result, per component (u, v, d) in units of its own sigma sqrt(Q_ii), rejected ones
  // included. A least-squares fit absorbs part of the noise, so with Q right robust_sigma
  // comes out near sqrt(redundancy); well below it, Q overstates the noise; above it, or rms
  // far above robust_sigma (heavy tails), the data hold more noise or wrong associations
  // than Q allows.
  struct ResidualCheck {
    int observations = 0;  // evaluated (in front of their camera at the result)
    Eigen::Vector3d rms = Eigen::Vector3d::Zero();
    Eigen::Vector3d robust_sigma = Eigen::Vector3d::Zero();  // 1.4826 * median |e_i| / sigma_i
    // (residuals - free parameters) / residuals of the last solve: the share of the noise
    // the residuals keep, in variance.
    double redundancy = 0.0;
  };
  ResidualCheck residual_check;

  double initial_cost = 0.0;  // Ceres' 1/2 sum |r|^2 (after the robust loss), first solve
  double final_cost = 0.0;    // of the last solve, over the observations kept
  int iterations = 0;         // summed over the solves
  int solves = 0;             // the first and one after each round of rejections
  std::string linear_solver;  // Ceres' name of the last solve's (e.g. "DENSE_SCHUR")
  // The share of the reduced camera system's off-diagonal pose blocks that are filled, at
  // the last solve (computed for linear_solver auto up to kDenseSchurMaxPoses; else -1).
  double reduced_system_density = -1.0;
  int num_residuals = 0;     // scalar residuals: 3 per observation kept, 6 per relative pose
  bool usable = false;       // Ceres: CONVERGENCE or NO_CONVERGENCE with a finite cost
  bool interrupted = false;  // options.stop ended it before it converged
  std::string termination;   // Ceres' termination type and message
  double solve_time_s = 0.0;
  double covariance_time_s = 0.0;
};

// 1.4826 x the median of `magnitudes` (|e_i| / sigma_i): the sigma of zero-mean normal
// errors, robust to outliers (the MAD of a zero-mean normal is 0.6745 sigma); 0 for none.
// The residual check's robust_sigma and a depth alignment's use it.
double RobustSigma(std::vector<double> magnitudes);

// Refines the problem's poses and features. Throws ConfigError when the options fail Check
// and DataError (naming the frame and the feature) when an observation refers to an unknown
// frame or feature, has a Q that is not positive definite, or its point lies behind the
// camera at the initial estimate. Poses and features without observations come back
// unchanged; those whose every observation was rejected, as the solve before left them.
BundleAdjustmentResult SolveBundleAdjustment(const BundleAdjustmentProblem& problem,
                                             const PinholeCamera& camera,
                                             const BundleAdjustmentOptions& options);

// d(alpha, beta, gamma) / d(phi) for R_true = Exp(phi) R(alpha, beta, gamma): the inverse
// of the map from Euler rates to the world-frame angular velocity. Singular at gimbal lock.
Eigen::Matrix3d EulerZyxFromRotationVectorJacobian(const Eigen::Vector3d& alpha_beta_gamma);

}  // namespace ieslam
