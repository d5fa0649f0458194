// The extended information filter with delayed states of Zhou et al. (2008), §V-B.
//
// The state is every pose added to the filter (6-vector, ZYX Euler, camera-to-world) and
// every 3-D feature, in the global frame. There is no motion model and no prediction step:
// a pose enters with its observations (eq. 9, linearised once at the current estimate) and
// the state is recovered by solving I X = i (eq. 10). The information matrix therefore stays
// sparse — a pose couples only with the features it observes — and is factored through its
// dense pose Schur complement while there are few poses, then by a sparse Cholesky factor
// (backend/dense_then_sparse_factor.h; docs/filter_internals.md); log det I and marginal
// covariances come from the factor without ever inverting I.
//
// The filter also scores candidate frames for the information-efficient selection (§V-A):
// the exact gain log det I(k+1) - log det I(k) of adding a candidate, without the expanded
// matrix, in O(|S|^3) per candidate once the joint covariance of the features the candidates
// observe has been recovered.
//
// Delayed feature initialisation (options.min_sightings): a feature enters the state only
// once that many filter poses have seen it. Until then its sightings (frame, z, Q) wait aside
// as a pending feature, adding nothing to the state; at the sighting that completes them it
// enters with all of them, the earlier ones linearised at their poses' current estimates.
// With every pose kept in the state (no motion model) that is exact in information form: the
// result is the filter that would have had the feature from its first sighting with those
// linearisation points. A feature seen from one pose only constrains no pose, and would
// otherwise cost three state dimensions for nothing.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "backend/information_factor.h"
#include "backend/sparse_cholesky.h"
#include "backend/upper_column_storage.h"
#include "core/camera.h"
#include "core/observation.h"
#include "core/option_table.h"
#include "core/pose.h"

namespace ieslam {

struct InformationFilterOptions {
  // Diagonal of the first pose's information block: the first pose is the origin.
  double anchor_information = 1e10;
  // Nested dissection: less fill-in than AMD, and the in-place updates after it touch
  // shorter paths to the root (docs/filter_internals.md).
  FillReducingOrdering ordering = FillReducingOrdering::kMetis;
  // Room kept in the factor for new variables, as a fraction of the state at each full
  // factorisation: updates are made in place until it runs out (backend/sparse_cholesky.h);
  // 0 refactors on every update.
  double spare_capacity = 0.25;
  // Up to this pose dimension (6 per pose) the matrix is factored through its dense pose
  // Schur complement (backend/pose_schur_factor.h); past it the sparse factor takes over for
  // good; 0: always sparse. Both are exact; the dense one is the faster while the poses are
  // few, and needs O(P^2) memory, at most ~(7.5P)^2 * 16 bytes (docs/filter_internals.md).
  int max_dense_pose_dim = 2400;
  // While the pose Schur complement factors the matrix: true recovers the state after an
  // update by conjugate gradients preconditioned with the last factor (the poses added since
  // eliminated exactly), and refactors only when a query needs the exact factor (log det,
  // covariances), when CG does not converge within cg_max_iterations, or when refactoring is
  // the cheaper (backend/pose_schur_factor.h); false refactors on every update. Updates that
  // follow a query stay exact (the selector queries once per added frame).
  // CG stops when the error's Mahalanobis norm is below cg_tolerance (up to the float
  // preconditioner's relative error): each state component is within cg_tolerance of its
  // standard deviation of the exact solve. The errors do not compound (each solve is bounded
  // on its own, against the exact I and i), and the default lies far below the digits the
  // filter's results are reported to (docs/filter_internals.md).
  bool iterative_recovery = true;
  double cg_tolerance = 1e-3;
  int cg_max_iterations = 60;
  // How many refactoring flops a CG flop costs, for the choice (PoseSchurOptions).
  double cg_flop_weight = 2.0;
  // A new pose is constrained only by its observations of features already in the map;
  // with (u, v, d) observations three features in general position determine it.
  int min_known_features = 3;
  // A feature closer than this to the camera plane (p_L.z) cannot be linearised.
  double min_depth_m = 1e-3;
  // Observations of known features can be screened before they enter
  // (backend/observation_gate.h): each must pass a chi-square test with 3 dof at gate_chi2
  // (16.27 is 1 - 1e-3, the bundle adjustment's gate: a right observation is lost once in a
  // thousand), then the kept set the joint test at joint_probability; 0 keeps all. Without
  // the gate every RANSAC inlier enters at full weight, and the bundle adjustment then
  // refuses a fifth of them on real data. The map's stated covariance is still too small
  // there, so the gate also sheds some right observations; the batch refinement weighs
  // them again (BundleAdjustmentOptions::refine_registered).
  double gate_chi2 = 16.27;
  bool joint_compatibility = true;
  double joint_probability = 0.999;
  // A frame whose kept set fails the joint test has its Q scaled by its variance factor (at
  // most max_noise_scale) before anything is dropped: what the sensor does that Q does not
  // model (motion blur, colour/depth time offsets under fast motion) shows in the
  // innovations frame by frame.
  bool adapt_noise = true;
  double max_noise_scale = 100.0;
  // Filter poses that must see a feature before it enters the state (delayed initialisation,
  // above): 1 adds every feature at its first sighting, as the paper does; 2 at its second,
  // which leaves the features one pose sees (about half on real sequences) out of the state
  // and out of the refinement's problem. The gate tests a pending feature, and the selector
  // scores a candidate, as the filter holding every feature would (GainTerms), so the two
  // differ by linearisation points: on every sequence measured they chose the same keyframes.
  // No more: a new pose is tied to the map only by features in the state or entering with
  // it, and at 3 the second pose would have neither.
  int min_sightings = 2;
  // At the end of a run (WithdrawInconsistent) every observation the filter took is tested
  // again, at the final estimate, against gate_chi2; the failing ones are withdrawn and the
  // state recovered, up to this many rounds (0: never; nothing is withdrawn without the gate).
  // The gate tests an observation against the map as it stood when its frame entered, and
  // cannot test a feature's first sighting at all; the bundle adjustment's rejection rounds
  // are this test at its own optimum.
  int max_withdrawal_rounds = 5;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<InformationFilterOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

// A pose (by frame id) or a feature (by feature id), for marginal covariance queries.
struct VariableRef {
  enum class Kind { kPose, kFeature };
  Kind kind = Kind::kPose;
  int64_t id = -1;

  static VariableRef Pose(int frame_id) { return {Kind::kPose, frame_id}; }
  static VariableRef Feature(int64_t feature_id) { return {Kind::kFeature, feature_id}; }
};

// The joint marginal covariance of a set of features, recovered once from the factor and
// then shared by every candidate of a look-ahead buffer; with delayed initialisation also of
// the poses that saw the pending features a candidate would bring into the state, and of
// the pending features themselves (InformationFilter::JointFeatureCovariance).
struct FeatureCovariance {
  std::vector<int64_t> feature_ids;
  std::unordered_map<int64_t, int> index;  // feature id -> position in feature_ids
  std::vector<int> frame_ids;              // the poses, after the features
  std::unordered_map<int, int> pose_row;   // frame id -> first row of its block in covariance
  Eigen::MatrixXd covariance;              // 3 * feature_ids.size() + 6 * frame_ids.size() square
};

// A sighting of a pending feature: the observation and the filter pose that made it.
struct FeatureSighting {
  int frame_id = -1;
  FeatureObservation observation;
};

// A feature seen by too few poses to be in the state yet (min_sightings).
struct PendingFeature {
  int64_t id = -1;
  std::vector<FeatureSighting> sightings;  // in the order the poses entered
};

// An observation the filter took in, with the point its information was linearised at: what
// withdrawing it subtracts.
struct TakenObservation {
  int frame_id = -1;
  FeatureObservation observation;
  Vector6d T_w_c = Vector6d::Zero();              // the pose's linearisation point
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();  // the feature's
  bool withdrawn = false;
};

// What InformationFilter::WithdrawInconsistent did.
struct WithdrawalStatistics {
  int tested = 0;     // observations held at the start
  int withdrawn = 0;  // in all rounds
  int rounds = 0;     // rounds that withdrew something
  // Observations failing the gate at the final estimate that stay: kept by the rules (a
  // feature's last, a pose's last ties), or left when the rounds ran out.
  int still_failing = 0;
  // Observations withdrawn and all put back, the matrix without them not being positive
  // definite (`withdrawn` is then 0); 0 normally.
  int put_back = 0;
  int cg_iterations = 0;  // of the rounds' solves, in all
  double seconds = 0.0;
};

// The three terms of an information gain (§V-A), in nats: the new features' own
// blocks, the new pose (log det C), and what the candidate tells about the features already
// in the map, log det(I + P_SS (A - B C^-1 B^T)). The first two are nearly the same for every
// candidate of a buffer under the equal-dimension rule; the map term is what sets them apart.
//
// The terms are always those of the filter that holds every feature from its first sighting
// (min_sightings 1), and total() is that filter's gain: with delayed initialisation the
// pending features count as the map's, and a feature the candidate is the first to see adds
// its own block although it waits aside. So the selector ranks the same candidates the same
// way whether features enter at their first sighting or their second; delayed
// initialisation changes what the state holds, not which frames enter it. (This filter's own
// gain, which InformationGain returns, differs from total() by the entering features' first
// sightings' own blocks, which it gains now, less the waiting features' own blocks.) pose is
// log det of the pose's information from the known and the pending features, and map what
// the candidate tells about the features and poses the filter holds or has seen, which is
// what the selector's threshold is about.
struct GainTerms {
  double new_features = 0.0;
  double pose = 0.0;
  double map = 0.0;
  double total() const { return new_features + pose + map; }
};

// Seconds spent in the last AddPose / AddFirstPose.
struct InformationFilterTimings {
  double linearize_s = 0.0;  // Jacobians and assembly of the new blocks
  double analyze_s = 0.0;    // ordering and symbolic analysis (full factorisations only)
  double factorize_s = 0.0;  // full factorisation, or the in-place update of the factor
  double solve_s = 0.0;      // recovery, I X = i
  double total_s = 0.0;
  int cg_iterations = 0;  // of the recovery by conjugate gradients (0: by substitution)
};

// Throws DataError naming the frame (frame_id < 0: a candidate) when a feature is observed
// twice, an observation is not finite or has no positive range, or a Q is not positive
// definite.
void ValidateObservations(int frame_id, const std::vector<FeatureObservation>& observations);
// What ValidateObservations throws for, or "".
std::string ObservationsProblem(int frame_id, const std::vector<FeatureObservation>& observations);

// The filter as it stands, for saving and restoring it: I's upper triangle in compressed
// columns, i, the state, and each pose's and feature's offset in them, in the order they
// were added (each pose after the features it brought).
struct FilterSnapshot {
  int dim = 0;
  std::vector<int> column_starts;  // dim + 1
  std::vector<int> rows;
  std::vector<double> values;
  Eigen::VectorXd information_vector;
  Eigen::VectorXd state;
  std::vector<std::pair<int, int>> pose_offsets;         // (frame id, offset)
  std::vector<std::pair<int64_t, int>> feature_offsets;  // (feature id, offset)
  std::vector<PendingFeature> pending;                   // by id
};

class InformationFilter {
 public:
  InformationFilter(const InformationFilterOptions& options, const PinholeCamera& camera);
  ~InformationFilter();
  InformationFilter(const InformationFilter&) = delete;
  InformationFilter& operator=(const InformationFilter&) = delete;

  // The first pose, anchored with options.anchor_information, and the features it sees
  // (initialised from their observations). Called once, before any AddPose.
  void AddFirstPose(int frame_id, const Vector6d& T_w_c,
                    const std::vector<FeatureObservation>& observations);

  // Appends a pose (initialised from the caller's registration estimate), initialises the
  // features that enter with it (options.min_sightings: never seen before, or pending and
  // seen often enough now) from their first sighting, keeps the sightings of the others
  // aside, applies the EIF update and recovers the state. A pending feature entering counts
  // as known for min_known_features: its earlier sightings tie the pose to the map. Throws
  // DataError naming the frame when the frame id is taken, an observation is malformed,
  // fewer than options.min_known_features known features are observed, or the updated
  // matrix is not positive definite; the filter is then unchanged.
  void AddPose(int frame_id, const Vector6d& T_w_c_initial,
               const std::vector<FeatureObservation>& observations);

  // Batch loading: while deferred, AddPose only accumulates the update (the new pose and
  // features enter the state at their initial values, and later frames are linearised
  // there); Recover() then factorises once and solves. For frames whose linearisation
  // points are already good (benchmarks, reloading a run). The queries below CHECK that no
  // recovery is pending. Recover() throws DataError if the matrix is not positive definite
  // (the deferred frames cannot be taken back one by one).
  void set_defer_recovery(bool defer) { defer_recovery_ = defer; }
  void Recover();
  bool recovery_pending() const { return recovery_pending_; }

  // Tests each observation taken in (since the filter was created: a restored snapshot does
  // not hold its observations' linearisation points) at the current estimate, chi-square with
  // 3 dof against options.gate_chi2, and withdraws the worst failing one of each feature: its
  // information, linearised where it was added, is subtracted from I and i, which is exact in
  // information form. A feature keeps its last observation, a pose other than the first
  // min_known_features observations of features other poses see too, and every pose its tie
  // to the first through them. The state is then recovered and the rest tested again, up
  // to options.max_withdrawal_rounds rounds. Does nothing without the gate. Should the
  // matrix without them not be positive definite, they all go back in: the filter is as
  // before.
  WithdrawalStatistics WithdrawInconsistent();
  const std::vector<TakenObservation>& taken_observations() const { return taken_; }

  // The filter as it stands (recovered).
  FilterSnapshot Snapshot() const;
  // An empty filter takes `snapshot` over: the same matrix, information vector, state and
  // variables, the matrix factored anew, so that later poses and queries go on as in the filter
  // it was taken of (backend/information_filter_snapshot.cc). Throws DataError, naming what is
  // wrong, when the snapshot does not hold together (sizes, a column that is not upper
  // triangular with its diagonal block last, variables that do not tile the state as the
  // filter lays it out) or its matrix is not positive definite.
  void Restore(const FilterSnapshot& snapshot);

  // Frees the factor, a cache of the information matrix (the dense pose Schur complement and
  // its Cholesky factor alone are (6 poses)^2 doubles each), for a caller done updating whose
  // later stages need the memory. The next update or query that needs a factor factors the
  // matrix anew, as Restore does, so its answers agree with the released factor's to
  // rounding (FactorNonzeros may differ: a sparse factor's ordering is chosen anew). That
  // costs one factorisation, and throws DataError where Restore would: where the dense factor
  // had handed over to the sparse one early, unable to recover the state, factoring anew may
  // fail. The filter must be recovered.
  void ReleaseFactor();

  bool HasPose(int frame_id) const { return pose_offset_.count(frame_id) > 0; }
  // In the state.
  bool HasFeature(int64_t feature_id) const { return feature_offset_.count(feature_id) > 0; }
  // Seen, but by fewer poses than min_sightings: not in the state.
  bool IsPending(int64_t feature_id) const { return pending_.count(feature_id) > 0; }
  // Whether `feature_id` enters the state with a new pose that observes it: not in it, and
  // with that sighting seen by min_sightings poses.
  bool Enters(int64_t feature_id) const;
  int num_pending_features() const { return static_cast<int>(pending_.size()); }
  // By id.
  std::vector<PendingFeature> PendingFeatures() const;
  Vector6d pose(int frame_id) const;
  Eigen::Vector3d feature(int64_t feature_id) const;

  int state_dim() const { return static_cast<int>(state_.size()); }
  int num_poses() const { return static_cast<int>(frame_ids_.size()); }
  int num_features() const { return static_cast<int>(feature_ids_.size()); }
  // In the order added.
  const std::vector<int>& frame_ids() const { return frame_ids_; }
  const std::vector<int64_t>& feature_ids() const { return feature_ids_; }
  // Where a variable's block starts in state() and information().
  int StateIndex(const VariableRef& variable) const;

  const Eigen::VectorXd& state() const {
    CheckRecovered();
    return state_;
  }
  const Eigen::VectorXd& information_vector() const { return info_vector_; }
  // The information matrix: its stored upper triangle (no copy), and both triangles.
  Eigen::Map<const Eigen::SparseMatrix<double>> information_upper() const;
  Eigen::SparseMatrix<double> Information() const;

  double LogDetInformation() const;
  Matrix6d PoseCovariance(int frame_id) const;
  // Joint covariance of the listed variables, blocks in the listed order (6 rows for a
  // pose, 3 for a feature), from solves against their columns only.
  Eigen::MatrixXd MarginalCovariance(const std::vector<VariableRef>& variables) const;

  // --- Information gain for the frame selector (§V-A; backend/information_filter_gain.cc). ---
  // Joint covariance of the known and the pending features among `feature_ids` (others are
  // skipped) and of the poses of `frame_ids` (which must be in the filter). A pending
  // feature's is what the filter holding it since its first sighting would have: that
  // sighting, with its Q, back-projected from its pose (MapFeature), whose block is added to
  // frame_ids. The known features come first, then the pending ones.
  FeatureCovariance JointFeatureCovariance(const std::vector<int64_t>& feature_ids,
                                           const std::vector<int>& frame_ids = {}) const;
  // A known feature's estimate, or a pending one's first sighting back-projected from that
  // pose's estimate (where the filter holding it since would have it, to first order).
  Eigen::Vector3d MapFeature(int64_t feature_id) const;
  // Features that adding a pose with `observations` brings into the state: the new ones
  // (min_sightings 1), or the pending ones this sighting completes.
  int CountEnteringFeatures(const std::vector<FeatureObservation>& observations) const;
  // Features among `observations` that no pose has seen (neither known nor pending).
  int CountFirstSightings(const std::vector<FeatureObservation>& observations) const;
  // The frames whose earlier sightings of those entering features join them: the poses
  // whose covariance InformationGain needs in `known`, ascending.
  std::vector<int> EarlierSightingFrames(const std::vector<FeatureObservation>& observations) const;
  // log det I(k+1) - log det I(k) for adding a pose at T_w_c_candidate with these
  // observations, counting only the first num_first_sightings_to_count features that no pose
  // has seen (CountFirstSightings; the equal-dimension rule: at min_sightings 1 they are the
  // state's new dimensions; a negative value counts all), and every pending feature the
  // candidate brings in; the first sightings that stay pending add nothing to it, and their
  // own blocks to `terms` (GainTerms). `known` must cover every known feature observed, and
  // the earlier sightings' poses of the entering pending features. Returns
  // -infinity when the observations cannot be linearised (one is malformed, as
  // ValidateObservations says, or a feature lies within min_depth_m of the camera's plane
  // or behind it) or cannot determine the pose.
  double InformationGain(const Vector6d& T_w_c_candidate,
                         const std::vector<FeatureObservation>& observations,
                         int num_first_sightings_to_count, const FeatureCovariance& known,
                         GainTerms* terms = nullptr) const;
  // The paper's way: log det of the explicitly expanded information matrix (with the same
  // counting rule), by a sparse factorisation of the whole expanded matrix. For checks and
  // for timing comparisons; -infinity when it is not positive definite.
  double LogDetExpandedInformation(const Vector6d& T_w_c_candidate,
                                   const std::vector<FeatureObservation>& observations,
                                   int num_first_sightings_to_count) const;

  const InformationFilterTimings& last_timings() const { return timings_; }
  int64_t FactorNonzeros() const;
  // True while the dense pose Schur complement factors the matrix (max_dense_pose_dim).
  bool uses_pose_schur() const;
  const InformationFilterOptions& options() const { return options_; }
  const PinholeCamera& camera() const { return camera_; }

 private:
  struct Linearization;
  struct LinearizedBlock;
  struct Undo;
  // The observation model h(T_w_c, p_w) (eqs. 4-8) linearised at one point.
  struct ObservationJacobians {
    Eigen::Vector3d p_w = Eigen::Vector3d::Zero();  // the feature's linearisation point
    double depth = 0.0;                             // of p_w in the camera
    Eigen::Vector3d h = Eigen::Vector3d::Zero();    // the predicted observation
    Matrix36d J_p = Matrix36d::Zero();
    Eigen::Matrix3d J_f = Eigen::Matrix3d::Zero();
  };

  // A factor of no matrix yet: the dense pose Schur complement, then the sparse one.
  std::unique_ptr<InformationFactor> NewFactor() const;

  // The sightings of a pending feature, or nullptr.
  const std::vector<FeatureSighting>* PendingSightings(int64_t feature_id) const {
    const auto it = pending_.find(feature_id);
    return it == pending_.end() ? nullptr : &it->second;
  }
  // A feature's linearisation point: a known one's current estimate; an entering one's first
  // sighting back-projected from its pose's estimate (from T_w_c when this is its first).
  Eigen::Vector3d LinearisationPoint(const Vector6d& T_w_c, const FeatureObservation& obs) const;
  // One observation's Jacobians at T_w_c and the feature's linearisation point (above).
  // False when that point lies within min_depth_m of the camera plane or behind it: it
  // cannot be linearised.
  bool LinearizeObservation(const Vector6d& T_w_c, const FeatureObservation& obs,
                            ObservationJacobians* jacobians) const;
  bool LinearizeAt(const Vector6d& T_w_c, const Eigen::Vector3d& p_w,
                   ObservationJacobians* jacobians) const;
  // Jacobians at the current estimate (new pose and new features at their initial values),
  // of at most max_first_sightings features that no pose has seen. Throws DataError naming
  // the frame when an observation cannot be linearised.
  Linearization Linearize(int frame_id, const Vector6d& T_w_c,
                          const std::vector<FeatureObservation>& observations,
                          int max_first_sightings) const;
  // Appends the new features' and the pose's columns and adds to the re-observed features'
  // diagonal blocks. `pose_prior` is added to the pose's diagonal block (the anchor).
  void AppendToMatrix(const Linearization& lin, double pose_prior,
                      UpperColumnStorage* matrix) const;
  void Update(int frame_id, const Vector6d& T_w_c,
              const std::vector<FeatureObservation>& observations, bool anchor);
  // Adds the update to the matrix and the information vector; returns what it overwrote.
  Undo AddToInformation(const Linearization& lin, const Vector6d& T_w_c, double pose_prior);
  void TakeBack(const Undo& undo);
  // What the factor needs of the update besides the matrix.
  InformationUpdate FactorUpdate(const Linearization& lin, int old_dim, double pose_prior) const;
  // Deferred: the new pose and features enter the state at their initial values.
  void GrowState(const Linearization& lin, int old_dim);
  // The Jacobians of an entering feature's earlier sightings at their poses' estimates and
  // the feature's linearisation point p_w, whitened (U J with U^T U = Q^-1): three rows per
  // sighting, J_f's 3 columns and each sighting's pose's 6. False when one cannot be
  // linearised.
  bool WhitenedEarlierSightings(const std::vector<FeatureSighting>& sightings,
                                const Eigen::Vector3d& p_w, Eigen::MatrixXd* J_f,
                                Eigen::MatrixXd* J_c) const;
  // Adds an entering feature's earlier sightings to its block (at their poses' estimates).
  // Throws DataError naming the frame when one cannot be linearised.
  void LinearizeEarlierSightings(int frame_id, const std::vector<FeatureSighting>& sightings,
                                 LinearizedBlock* block) const;
  // Subtracts what `taken` added to I and i (at its linearisation points): `sign` -1
  // withdraws it, +1 puts it back.
  void AddTakenInformation(const TakenObservation& taken, double sign);
  // The observations of taken_ still in I that fail the gate at the current state, as
  // (squared whitened residual, index), worst first.
  std::vector<std::pair<double, int>> FailingObservations() const;
  // Records the new pose's and features' places once their update is accepted, and the
  // sightings that stay pending.
  void Register(const Linearization& lin, int frame_id, int old_dim, int new_dim);
  std::vector<int> ScalarIndices(const std::vector<VariableRef>& variables) const;
  void CheckRecovered() const;
  // Recovered, and the factor exact (lazy updates leave only a preconditioner): what log det
  // and covariances need. Refactors if needed, under factor_mutex_.
  void EnsureExactFactor() const;
  // The factor, factored anew from the matrix after ReleaseFactor. The caller holds
  // factor_mutex_ in const queries.
  InformationFactor& Factor() const;
  // The current estimate (the initial value while a recovery is pending).
  Eigen::Vector3d FeatureEstimate(int64_t feature_id) const {
    return state_.segment<3>(StateIndex(VariableRef::Feature(feature_id)));
  }

  InformationFilterOptions options_;
  PinholeCamera camera_;
  UpperColumnStorage matrix_;
  // Const queries may make it exact (EnsureExactFactor) or build it anew (Factor): its state
  // is a cache of the matrix, which they do not change. Null after ReleaseFactor.
  mutable std::unique_ptr<InformationFactor> factor_;
  mutable std::mutex factor_mutex_;
  Eigen::VectorXd info_vector_;
  Eigen::VectorXd state_;
  std::vector<int> frame_ids_;
  std::vector<int64_t> feature_ids_;
  std::unordered_map<int, int> pose_offset_;
  std::unordered_map<int64_t, int> feature_offset_;
  // Features not in the state yet (min_sightings), by id: sightings in the order made.
  std::map<int64_t, std::vector<FeatureSighting>> pending_;
  // The observations taken in since the filter was created or restored, in that order, the
  // withdrawn ones flagged (WithdrawInconsistent).
  std::vector<TakenObservation> taken_;
  // Poses and features a snapshot restored: the first frame_ids_ and feature_ids_ (their
  // observations are not in taken_).
  int restored_poses_ = 0;
  int restored_features_ = 0;
  InformationFilterTimings timings_;
  bool defer_recovery_ = false;
  bool recovery_pending_ = false;
};

}  // namespace ieslam
