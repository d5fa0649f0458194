#include "backend/information_filter.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_set>
#include <utility>

#include <glog/logging.h>
#include <Eigen/Cholesky>

#include "backend/dense_then_sparse_factor.h"
#include "backend/pose_schur_information_factor.h"
#include "backend/sparse_information_factor.h"
#include "core/error.h"
#include "core/stopwatch.h"

namespace ieslam {

namespace {

std::string FrameName(int frame_id) {
  return frame_id < 0 ? std::string("candidate frame") : "frame " + std::to_string(frame_id);
}

// The factorisations' options, from the filter's.
SparseCholeskyOptions SparseFactorOptions(const InformationFilterOptions& options) {
  return {options.ordering, options.spare_capacity};
}

PoseSchurOptions DenseFactorOptions(const InformationFilterOptions& options) {
  // The window's and the float renewal's settings are the dense factor's own.
  const PoseSchurOptions own;
  return {own.prefetch,           own.evict_after,
          options.cg_tolerance,   options.cg_max_iterations,
          options.cg_flop_weight, own.single_speedup};
}

const InformationFilterOptions& Checked(const InformationFilterOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("InformationFilterOptions: " + why);
  return options;
}

bool ParseOrdering(const std::string& name, FillReducingOrdering* ordering) {
  const std::pair<const char*, FillReducingOrdering> names[] = {
      {"amd", FillReducingOrdering::kAmd},
      {"cholmod", FillReducingOrdering::kCholmodChoice},
      {"natural", FillReducingOrdering::kNatural},
      {"metis", FillReducingOrdering::kMetis}};
  for (const auto& [text, value] : names) {
    if (name == text) {
      *ordering = value;
      return true;
    }
  }
  return false;
}

std::string OrderingName(FillReducingOrdering ordering) {
  switch (ordering) {
    case FillReducingOrdering::kAmd:
      return "amd";
    case FillReducingOrdering::kCholmodChoice:
      return "cholmod";
    case FillReducingOrdering::kNatural:
      return "natural";
    case FillReducingOrdering::kMetis:
      return "metis";
  }
  return "?";
}

}  // namespace

const OptionTable<InformationFilterOptions>& InformationFilterOptions::Table() {
  static const OptionTable<InformationFilterOptions>* table = [] {
    using O = InformationFilterOptions;
    auto* t = new OptionTable<O>;
    t->Double("anchor_information", &O::anchor_information,
              "the first pose's information (it is the origin)")
        .Above(0.0);
    t->Bool("iterative_recovery", &O::iterative_recovery,
            "dense factor: 0 refactors and solves exactly at every update (eq. 10)");
    t->Double("cg_tolerance", &O::cg_tolerance,
              "iterative recovery: error below this many standard deviations")
        .Above(0.0);
    t->Int("max_dense_pose_dim", &O::max_dense_pose_dim,
           "dense pose Schur factor up to this pose dimension, sparse past it (0)");
    t->Enum("ordering", &O::ordering, ParseOrdering, OrderingName, "amd|cholmod|natural|metis",
            "the sparse factor's fill-reducing ordering");
    t->Double("spare_capacity", &O::spare_capacity,
              "room for new variables in the sparse factor, share of the state")
        .Min(0.0);
    t->Int("cg_max_iterations", &O::cg_max_iterations, "conjugate-gradient iterations at most")
        .Min(1);
    t->Double("cg_flop_weight", &O::cg_flop_weight,
              "refactoring flops a conjugate-gradient flop costs, for the choice")
        .Min(0.0);
    t->Int("min_known_features", &O::min_known_features, "map features a new pose must observe")
        .Min(3);
    t->Double("min_depth_m", &O::min_depth_m,
              "a feature closer to the camera plane is not linearised")
        .Above(0.0);
    t->Double("gate_chi2", &O::gate_chi2,
              "chi-square (3 dof) an observation of a known feature must pass (0: no gate)")
        .Min(0.0);
    t->Bool("joint_compatibility", &O::joint_compatibility,
            "test a frame's kept observations jointly, dropping the worst until they pass");
    t->Double("joint_probability", &O::joint_probability, "the joint test's chi-square probability")
        .Above(0.5)
        .Below(1.0);
    t->Bool("adapt_noise", &O::adapt_noise,
            "scale a jointly incompatible frame's Q by its variance factor before dropping any");
    t->Double("max_noise_scale", &O::max_noise_scale, "the largest such scale of Q").Min(1.0);
    t->Int("min_sightings", &O::min_sightings,
           "filter poses that see a feature before it enters the state (2: delayed)")
        .Range(1, 2);
    t->Int("max_withdrawal_rounds", &O::max_withdrawal_rounds,
           "end of a run: rounds withdrawing observations the estimate contradicts (0: none)")
        .Min(0);
    t->Require([](const O& o) {
      return o.max_dense_pose_dim == 0 || o.max_dense_pose_dim >= 6
                 ? std::string()
                 : "max_dense_pose_dim must be 0 (always sparse) or at least 6 (one pose), got " +
                       std::to_string(o.max_dense_pose_dim);
    });
    return t;
  }();
  return *table;
}

std::string ObservationsProblem(int frame_id, const std::vector<FeatureObservation>& observations) {
  std::unordered_set<int64_t> seen;
  for (const FeatureObservation& obs : observations) {
    if (!seen.insert(obs.feature_id).second) {
      return FrameName(frame_id) + " observes feature " + std::to_string(obs.feature_id) + " twice";
    }
    if (!obs.z.allFinite() || !(obs.z.z() > 0.0)) {
      std::ostringstream msg;
      msg << FrameName(frame_id) << ": observation of feature " << obs.feature_id
          << " is not finite or has range <= 0: z = " << obs.z.transpose();
      return msg.str();
    }
    if (!obs.Q.allFinite() || Eigen::LLT<Eigen::Matrix3d>(obs.Q).info() != Eigen::Success) {
      std::ostringstream msg;
      msg << FrameName(frame_id) << ": noise covariance Q of feature " << obs.feature_id
          << " is not positive definite:\n"
          << obs.Q;
      return msg.str();
    }
  }
  return std::string();
}

void ValidateObservations(int frame_id, const std::vector<FeatureObservation>& observations) {
  const std::string problem = ObservationsProblem(frame_id, observations);
  if (!problem.empty()) throw DataError(problem);
}

// One feature's share of an update: what its observation from the new pose adds, and for a
// feature entering on a later sighting what its earlier sightings add (H^T Q^-1 H and
// H^T Q^-1 (z - h + H X), split into the blocks they touch).
struct InformationFilter::LinearizedBlock {
  // An earlier sighting, from a pose in the state.
  struct Earlier {
    int pose_offset = 0;
    int frame_id = -1;
    FeatureObservation observation;
    Vector6d T_w_c = Vector6d::Zero();  // the pose's linearisation point
    Matrix6d I_cc = Matrix6d::Zero();
    Eigen::Matrix<double, 6, 3> I_cf = Eigen::Matrix<double, 6, 3>::Zero();
    Vector6d i_c = Vector6d::Zero();
  };
  int64_t feature_id = -1;
  FeatureObservation observation;                 // from the pose being added
  bool is_new = false;                            // enters the state with this pose
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();  // linearisation point of the feature
  Eigen::Matrix3d I_ff = Eigen::Matrix3d::Zero();
  Eigen::Matrix<double, 6, 3> I_pf = Eigen::Matrix<double, 6, 3>::Zero();
  Eigen::Vector3d i_f = Eigen::Vector3d::Zero();
  std::vector<Earlier> earlier;  // by pose offset
};

// What an update brings.
struct InformationFilter::Linearization {
  using Block = LinearizedBlock;
  Vector6d T_w_c = Vector6d::Zero();
  Matrix6d I_pp = Matrix6d::Zero();
  Vector6d i_p = Vector6d::Zero();
  std::vector<Block> blocks;  // known features, then new ones, each in observation order
  int num_known = 0;
  int num_new = 0;
  int num_tied = 0;  // new ones with earlier sightings: they tie the pose to the map
  // Sightings of features that do not enter (min_sightings): they wait aside.
  std::vector<FeatureObservation> deferred;
};

// What an update overwrites, to take it back when the factor refuses it.
struct InformationFilter::Undo {
  int old_dim = 0;
  std::vector<std::pair<int, Eigen::MatrixXd>> saved_blocks;  // re-observed features' blocks
  Eigen::VectorXd saved_info_vector;
};

InformationFilter::InformationFilter(const InformationFilterOptions& options,
                                     const PinholeCamera& camera)
    : options_(Checked(options)), camera_(camera), factor_(NewFactor()) {}

std::unique_ptr<InformationFactor> InformationFilter::NewFactor() const {
  const PoseSchurOptions dense = DenseFactorOptions(options_);
  const SparseCholeskyOptions sparse = SparseFactorOptions(options_);
  return std::make_unique<DenseThenSparseFactor>(
      options_.max_dense_pose_dim, [dense]() { return MakePoseSchurInformationFactor(dense); },
      [sparse]() { return MakeSparseInformationFactor(sparse); });
}

InformationFilter::~InformationFilter() = default;

bool InformationFilter::Enters(int64_t feature_id) const {
  if (HasFeature(feature_id)) return false;
  const std::vector<FeatureSighting>* sightings = PendingSightings(feature_id);
  const int seen = sightings == nullptr ? 0 : static_cast<int>(sightings->size());
  return seen + 1 >= options_.min_sightings;
}

std::vector<PendingFeature> InformationFilter::PendingFeatures() const {
  std::vector<PendingFeature> pending;
  pending.reserve(pending_.size());
  for (const auto& [id, sightings] : pending_) pending.push_back({id, sightings});
  return pending;
}

Eigen::Vector3d InformationFilter::LinearisationPoint(const Vector6d& T_w_c,
                                                      const FeatureObservation& obs) const {
  if (HasFeature(obs.feature_id)) return FeatureEstimate(obs.feature_id);
  // The earliest pose has been estimated longest; the candidate's is only registered.
  if (IsPending(obs.feature_id)) return MapFeature(obs.feature_id);
  return ObservationToWorld(T_w_c, obs.z, camera_);
}

bool InformationFilter::LinearizeObservation(const Vector6d& T_w_c, const FeatureObservation& obs,
                                             ObservationJacobians* jacobians) const {
  return LinearizeAt(T_w_c, LinearisationPoint(T_w_c, obs), jacobians);
}

bool InformationFilter::LinearizeAt(const Vector6d& T_w_c, const Eigen::Vector3d& p_w,
                                    ObservationJacobians* jacobians) const {
  jacobians->p_w = p_w;
  jacobians->depth = WorldToCamera(T_w_c, jacobians->p_w).z();
  if (!(jacobians->depth > options_.min_depth_m)) return false;
  jacobians->h =
      PredictObservation(T_w_c, jacobians->p_w, camera_, &jacobians->J_p, &jacobians->J_f);
  return true;
}

void InformationFilter::LinearizeEarlierSightings(int frame_id,
                                                  const std::vector<FeatureSighting>& sightings,
                                                  LinearizedBlock* block) const {
  for (const FeatureSighting& sighting : sightings) {
    LinearizedBlock::Earlier earlier;
    earlier.pose_offset = pose_offset_.at(sighting.frame_id);
    earlier.frame_id = sighting.frame_id;
    earlier.observation = sighting.observation;
    const Vector6d T_w_c = state_.segment<6>(earlier.pose_offset);
    earlier.T_w_c = T_w_c;
    ObservationJacobians jacobians;
    if (!LinearizeAt(T_w_c, block->p_w, &jacobians)) {
      std::ostringstream msg;
      msg << FrameName(frame_id) << ": feature " << block->feature_id << " lies at depth "
          << jacobians.depth << " m in frame " << sighting.frame_id
          << ", which saw it earlier; cannot linearise that sighting";
      throw DataError(msg.str());
    }
    const FeatureObservation& obs = sighting.observation;
    const Eigen::Matrix3d W = obs.Q.inverse();
    const Eigen::Matrix<double, 6, 3> JcT_W = jacobians.J_p.transpose() * W;
    const Eigen::Matrix3d JfT_W = jacobians.J_f.transpose() * W;
    // Eq. 9 at the earlier pose's current estimate.
    const Eigen::Vector3d z_lin =
        obs.z - jacobians.h + jacobians.J_p * T_w_c + jacobians.J_f * block->p_w;
    earlier.I_cc = JcT_W * jacobians.J_p;
    earlier.I_cf = JcT_W * jacobians.J_f;
    earlier.i_c = JcT_W * z_lin;
    block->I_ff += JfT_W * jacobians.J_f;
    block->i_f += JfT_W * z_lin;
    block->earlier.push_back(earlier);
  }
  std::stable_sort(block->earlier.begin(), block->earlier.end(),
                   [](const auto& a, const auto& b) { return a.pose_offset < b.pose_offset; });
}

InformationFilter::Linearization InformationFilter::Linearize(
    int frame_id, const Vector6d& T_w_c, const std::vector<FeatureObservation>& observations,
    int max_first_sightings) const {
  ValidateObservations(frame_id, observations);
  Linearization lin;
  lin.T_w_c = T_w_c;
  std::vector<Linearization::Block> new_blocks;
  int first_sightings = 0;
  for (const FeatureObservation& obs : observations) {
    Linearization::Block block;
    block.feature_id = obs.feature_id;
    block.observation = obs;
    block.is_new = !HasFeature(obs.feature_id);
    if (block.is_new && !Enters(obs.feature_id)) {
      lin.deferred.push_back(obs);
      continue;
    }
    if (block.is_new && PendingSightings(obs.feature_id) == nullptr &&
        first_sightings++ >= max_first_sightings) {
      continue;
    }
    ObservationJacobians jacobians;
    if (!LinearizeObservation(T_w_c, obs, &jacobians)) {
      std::ostringstream msg;
      msg << FrameName(frame_id) << ": feature " << obs.feature_id << " lies at depth "
          << jacobians.depth
          << " m in the camera at its estimated pose; cannot linearise its observation";
      throw DataError(msg.str());
    }
    block.p_w = jacobians.p_w;
    const Matrix36d& J_p = jacobians.J_p;
    const Eigen::Matrix3d& J_f = jacobians.J_f;
    const Eigen::Vector3d& h = jacobians.h;
    const Eigen::Matrix3d W = obs.Q.inverse();
    const Eigen::Matrix<double, 6, 3> JpT_W = J_p.transpose() * W;
    const Eigen::Matrix3d JfT_W = J_f.transpose() * W;
    // Eq. 9: the linearised measurement z - h(X) + H X at the current estimate X(k).
    const Eigen::Vector3d z_lin = obs.z - h + J_p * T_w_c + J_f * block.p_w;
    lin.I_pp += JpT_W * J_p;
    lin.i_p += JpT_W * z_lin;
    block.I_pf = JpT_W * J_f;
    block.I_ff = JfT_W * J_f;
    block.i_f = JfT_W * z_lin;
    if (block.is_new) {
      const std::vector<FeatureSighting>* earlier = PendingSightings(obs.feature_id);
      if (earlier != nullptr) {
        LinearizeEarlierSightings(frame_id, *earlier, &block);
        ++lin.num_tied;
      }
      new_blocks.push_back(std::move(block));
    } else {
      lin.blocks.push_back(std::move(block));
    }
  }
  lin.num_known = static_cast<int>(lin.blocks.size());
  lin.num_new = static_cast<int>(new_blocks.size());
  lin.blocks.insert(lin.blocks.end(), new_blocks.begin(), new_blocks.end());
  return lin;
}

void InformationFilter::AppendToMatrix(const Linearization& lin, double pose_prior,
                                       UpperColumnStorage* matrix) const {
  // New features first, then the pose: the pose's couplings then all live in its columns.
  const int first_new = matrix->dim();
  std::vector<std::pair<int, const Linearization::Block*>> coupled;  // (offset, block)
  coupled.reserve(lin.blocks.size());
  for (int b = 0; b < static_cast<int>(lin.blocks.size()); ++b) {
    const Linearization::Block& block = lin.blocks[b];
    if (!block.is_new) {
      const int offset = feature_offset_.at(block.feature_id);
      matrix->AddToDiagonalBlock(offset, block.I_ff);
      coupled.emplace_back(offset, &block);
      continue;
    }
    const int offset = first_new + 3 * (b - lin.num_known);
    CHECK_EQ(offset, matrix->dim());
    // A feature entering on a later sighting couples with the earlier poses in its own
    // columns, and adds to their diagonal blocks.
    for (int k = 0; k < 3; ++k) {
      matrix->StartColumn();
      for (const LinearizedBlock::Earlier& earlier : block.earlier) {
        for (int r = 0; r < 6; ++r) matrix->Append(earlier.pose_offset + r, earlier.I_cf(r, k));
      }
      for (int r = 0; r <= k; ++r) matrix->Append(offset + r, block.I_ff(r, k));
    }
    for (const LinearizedBlock::Earlier& earlier : block.earlier) {
      matrix->AddToDiagonalBlock(earlier.pose_offset, earlier.I_cc);
    }
    coupled.emplace_back(offset, &block);
  }
  std::sort(coupled.begin(), coupled.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  const int pose_offset = matrix->dim();
  for (int k = 0; k < 6; ++k) {
    matrix->StartColumn();
    for (const auto& [offset, block] : coupled) {
      for (int r = 0; r < 3; ++r) matrix->Append(offset + r, block->I_pf(k, r));
    }
    for (int r = 0; r <= k; ++r) {
      matrix->Append(pose_offset + r, lin.I_pp(r, k) + (r == k ? pose_prior : 0.0));
    }
  }
}

void InformationFilter::AddFirstPose(int frame_id, const Vector6d& T_w_c,
                                     const std::vector<FeatureObservation>& observations) {
  CHECK_EQ(num_poses(), 0) << "AddFirstPose is for the first pose only";
  Update(frame_id, T_w_c, observations, /*anchor=*/true);
}

void InformationFilter::AddPose(int frame_id, const Vector6d& T_w_c_initial,
                                const std::vector<FeatureObservation>& observations) {
  CHECK_GT(num_poses(), 0) << "AddFirstPose must come first";
  Update(frame_id, T_w_c_initial, observations, /*anchor=*/false);
}

void InformationFilter::Update(int frame_id, const Vector6d& T_w_c,
                               const std::vector<FeatureObservation>& observations, bool anchor) {
  const auto start = std::chrono::steady_clock::now();
  if (HasPose(frame_id)) {
    throw DataError(FrameName(frame_id) + " is already in the filter");
  }
  // A released factor is built from the matrix before the update changes it.
  InformationFactor& factor = Factor();
  if (!T_w_c.allFinite()) throw DataError(FrameName(frame_id) + ": initial pose is not finite");
  const Linearization lin = Linearize(frame_id, T_w_c, observations, INT_MAX);
  // A pending feature entering now ties the pose to the earlier poses that saw it.
  const int tying = lin.num_known + lin.num_tied;
  if (!anchor && tying < options_.min_known_features) {
    throw DataError(FrameName(frame_id) + " observes " + std::to_string(tying) +
                    " features already in the map; a new pose needs at least " +
                    std::to_string(options_.min_known_features));
  }
  const double prior = anchor ? options_.anchor_information : 0.0;
  const Undo undo = AddToInformation(lin, T_w_c, prior);
  const int old_dim = undo.old_dim, new_dim = matrix_.dim();
  const InformationUpdate update = FactorUpdate(lin, old_dim, prior);
  timings_.linearize_s = SecondsSince(start);
  if (defer_recovery_) {
    // No factorisation (the factor only notes what the update touched, for its next one).
    factor.AddDeferred(matrix_, update);
    GrowState(lin, old_dim);
    Register(lin, frame_id, old_dim, new_dim);
    recovery_pending_ = true;
    timings_.analyze_s = timings_.factorize_s = timings_.solve_s = 0.0;
    timings_.cg_iterations = 0;
    timings_.total_s = SecondsSince(start);
    return;
  }
  // Eq. 10, I X = i, from the previous estimate (an iterative recovery reads the poses).
  Eigen::VectorXd guess = state_;
  guess.conservativeResize(new_dim);
  guess.tail<6>() = T_w_c;
  Eigen::VectorXd solution;
  if (factor.AddAndSolve(matrix_, update, /*keep_exact=*/!options_.iterative_recovery, info_vector_,
                         guess, &solution) != FactorStatus::kOk) {
    TakeBack(undo);
    // (With deferred frames pending there was no factor of the old matrix to restore.)
    factor.Restore(matrix_, /*factored=*/!recovery_pending_);
    throw DataError("adding " + FrameName(frame_id) +
                    " makes the information matrix not positive definite (degenerate "
                    "observations?)");
  }
  Register(lin, frame_id, old_dim, new_dim);
  state_ = std::move(solution);
  recovery_pending_ = false;  // the deferred frames were factored in too
  const FactorTimings& factor_timings = factor.timings();
  timings_.analyze_s = factor_timings.analyze_s;
  timings_.factorize_s = factor_timings.factorize_s;
  timings_.solve_s = factor_timings.solve_s;
  timings_.cg_iterations = factor_timings.cg_iterations;
  timings_.total_s = SecondsSince(start);
}

InformationFilter::Undo InformationFilter::AddToInformation(const Linearization& lin,
                                                            const Vector6d& T_w_c,
                                                            double pose_prior) {
  Undo undo;
  undo.old_dim = matrix_.dim();
  for (int b = 0; b < lin.num_known; ++b) {
    const int offset = feature_offset_.at(lin.blocks[b].feature_id);
    undo.saved_blocks.emplace_back(offset, matrix_.DiagonalBlock(offset, 3));
  }
  for (int b = lin.num_known; b < static_cast<int>(lin.blocks.size()); ++b) {
    for (const LinearizedBlock::Earlier& earlier : lin.blocks[b].earlier) {
      undo.saved_blocks.emplace_back(earlier.pose_offset,
                                     matrix_.DiagonalBlock(earlier.pose_offset, 6));
    }
  }
  undo.saved_info_vector = info_vector_;
  AppendToMatrix(lin, pose_prior, &matrix_);
  info_vector_.conservativeResize(matrix_.dim());
  for (int b = 0; b < static_cast<int>(lin.blocks.size()); ++b) {
    const Linearization::Block& block = lin.blocks[b];
    const int offset = block.is_new ? undo.old_dim + 3 * (b - lin.num_known)
                                    : feature_offset_.at(block.feature_id);
    if (block.is_new) info_vector_.segment<3>(offset).setZero();
    info_vector_.segment<3>(offset) += block.i_f;
    for (const LinearizedBlock::Earlier& earlier : block.earlier) {
      info_vector_.segment<6>(earlier.pose_offset) += earlier.i_c;
    }
  }
  info_vector_.tail<6>() = lin.i_p + pose_prior * T_w_c;
  return undo;
}

void InformationFilter::TakeBack(const Undo& undo) {
  matrix_.Truncate(undo.old_dim);
  for (const auto& [offset, block] : undo.saved_blocks) matrix_.SetDiagonalBlock(offset, block);
  info_vector_ = undo.saved_info_vector;
}

InformationUpdate InformationFilter::FactorUpdate(const Linearization& lin, int old_dim,
                                                  double pose_prior) const {
  InformationUpdate update;
  update.old_dim = old_dim;
  update.pose_block = lin.I_pp + pose_prior * Matrix6d::Identity();
  for (int b = 0; b < static_cast<int>(lin.blocks.size()); ++b) {
    const Linearization::Block& block = lin.blocks[b];
    const int offset =
        block.is_new ? old_dim + 3 * (b - lin.num_known) : feature_offset_.at(block.feature_id);
    ObservationBlocks blocks;
    blocks.feature_offset = offset;
    blocks.is_new = block.is_new;
    blocks.I_ff = block.I_ff;
    blocks.I_pf = block.I_pf;
    for (const LinearizedBlock::Earlier& earlier : block.earlier) {
      blocks.earlier.push_back({earlier.pose_offset, earlier.I_cc, earlier.I_cf});
    }
    update.observations.push_back(std::move(blocks));
  }
  return update;
}

void InformationFilter::GrowState(const Linearization& lin, int old_dim) {
  state_.conservativeResize(matrix_.dim());
  for (int b = lin.num_known; b < static_cast<int>(lin.blocks.size()); ++b) {
    state_.segment<3>(old_dim + 3 * (b - lin.num_known)) = lin.blocks[b].p_w;
  }
  state_.tail<6>() = lin.T_w_c;
}

void InformationFilter::Register(const Linearization& lin, int frame_id, int old_dim, int new_dim) {
  for (int b = lin.num_known; b < static_cast<int>(lin.blocks.size()); ++b) {
    feature_offset_[lin.blocks[b].feature_id] = old_dim + 3 * (b - lin.num_known);
    feature_ids_.push_back(lin.blocks[b].feature_id);
    if (!lin.blocks[b].earlier.empty()) pending_.erase(lin.blocks[b].feature_id);
  }
  for (const FeatureObservation& obs : lin.deferred) {
    pending_[obs.feature_id].push_back({frame_id, obs});
  }
  for (const Linearization::Block& block : lin.blocks) {
    for (const LinearizedBlock::Earlier& earlier : block.earlier) {
      taken_.push_back({earlier.frame_id, earlier.observation, earlier.T_w_c, block.p_w});
    }
    taken_.push_back({frame_id, block.observation, lin.T_w_c, block.p_w});
  }
  pose_offset_[frame_id] = new_dim - 6;
  frame_ids_.push_back(frame_id);
}

void InformationFilter::Recover() {
  if (!recovery_pending_) return;
  const auto start = std::chrono::steady_clock::now();
  if (!factor_->Refactor(matrix_)) {
    throw DataError("the deferred frames (last: " + FrameName(frame_ids_.back()) +
                    ") make the information matrix not positive definite");
  }
  const auto solve_start = std::chrono::steady_clock::now();
  state_ = factor_->Solve(info_vector_);
  recovery_pending_ = false;
  timings_.linearize_s = 0.0;
  timings_.analyze_s = factor_->timings().analyze_s;
  timings_.factorize_s = factor_->timings().factorize_s;
  timings_.solve_s = SecondsSince(solve_start);
  timings_.cg_iterations = 0;
  timings_.total_s = SecondsSince(start);
}

void InformationFilter::CheckRecovered() const {
  CHECK(!recovery_pending_) << "deferred updates are pending: call Recover() first";
}

void InformationFilter::ReleaseFactor() {
  CheckRecovered();
  factor_.reset();
}

InformationFactor& InformationFilter::Factor() const {
  if (factor_ != nullptr) return *factor_;
  if (state_dim() == 0) {
    factor_ = NewFactor();
  } else {
    InformationFilter fresh(options_, camera_);
    fresh.Restore(Snapshot());
    factor_ = std::move(fresh.factor_);
  }
  return *factor_;
}

void InformationFilter::EnsureExactFactor() const {
  CheckRecovered();
  const std::lock_guard<std::mutex> lock(factor_mutex_);
  Factor().MakeExact();
}

int64_t InformationFilter::FactorNonzeros() const {
  CheckRecovered();
  const std::lock_guard<std::mutex> lock(factor_mutex_);
  return Factor().FactorNonzeros();
}

bool InformationFilter::uses_pose_schur() const {
  const std::lock_guard<std::mutex> lock(factor_mutex_);
  return Factor().uses_pose_schur();
}

Vector6d InformationFilter::pose(int frame_id) const {
  CheckRecovered();
  return state_.segment<6>(StateIndex(VariableRef::Pose(frame_id)));
}

Eigen::Vector3d InformationFilter::feature(int64_t feature_id) const {
  CheckRecovered();
  return state_.segment<3>(StateIndex(VariableRef::Feature(feature_id)));
}

int InformationFilter::StateIndex(const VariableRef& variable) const {
  if (variable.kind == VariableRef::Kind::kPose) {
    const auto it = pose_offset_.find(static_cast<int>(variable.id));
    CHECK(it != pose_offset_.end()) << "frame " << variable.id << " is not in the filter";
    return it->second;
  }
  const auto it = feature_offset_.find(variable.id);
  CHECK(it != feature_offset_.end()) << "feature " << variable.id << " is not in the filter";
  return it->second;
}

Eigen::Map<const Eigen::SparseMatrix<double>> InformationFilter::information_upper() const {
  return matrix_.Upper();
}

Eigen::SparseMatrix<double> InformationFilter::Information() const { return matrix_.Full(); }

double InformationFilter::LogDetInformation() const {
  EnsureExactFactor();
  return factor_->LogDet();
}

std::vector<int> InformationFilter::ScalarIndices(const std::vector<VariableRef>& variables) const {
  std::vector<int> indices;
  for (const VariableRef& variable : variables) {
    const int offset = StateIndex(variable);
    const int size = variable.kind == VariableRef::Kind::kPose ? 6 : 3;
    for (int k = 0; k < size; ++k) indices.push_back(offset + k);
  }
  return indices;
}

Eigen::MatrixXd InformationFilter::MarginalCovariance(
    const std::vector<VariableRef>& variables) const {
  EnsureExactFactor();
  return factor_->InverseSubmatrix(ScalarIndices(variables));
}

Matrix6d InformationFilter::PoseCovariance(int frame_id) const {
  return MarginalCovariance({VariableRef::Pose(frame_id)});
}

double InformationFilter::LogDetExpandedInformation(
    const Vector6d& T_w_c_candidate, const std::vector<FeatureObservation>& observations,
    int num_first_sightings_to_count) const {
  const int max_first = num_first_sightings_to_count < 0 ? INT_MAX : num_first_sightings_to_count;
  const Linearization lin = Linearize(-1, T_w_c_candidate, observations, max_first);
  // The first sightings counted: those that entered, or with min_sightings above 1 (where
  // they wait aside, unlinearised) as many as the candidate has, up to the count.
  const int counted = options_.min_sightings > 1
                          ? std::min(CountFirstSightings(observations), max_first)
                          : lin.num_new - lin.num_tied;
  CHECK(num_first_sightings_to_count < 0 || counted == num_first_sightings_to_count)
      << "the candidate has " << counted << " first sightings, asked to count "
      << num_first_sightings_to_count;
  UpperColumnStorage expanded = matrix_;
  AppendToMatrix(lin, 0.0, &expanded);
  SparseCholesky cholesky({options_.ordering});  // no spare slots: one factorisation
  if (!cholesky.Factorize(expanded, true)) return -std::numeric_limits<double>::infinity();
  return cholesky.LogDet();
}

}  // namespace ieslam
