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

#include "core/error.h"
#include "core/stopwatch.h"

namespace ieslam {

namespace {

std::string FrameName(int frame_id) {
  return frame_id < 0 ? std::string("candidate frame") : "frame " + std::to_string(frame_id);
}

}  // namespace

bool InformationFilterOptions::Check(std::string* why) const {
  std::ostringstream reason;
  if (!(anchor_information > 0.0) || !std::isfinite(anchor_information)) {
    reason << "anchor_information must be positive and finite, got " << anchor_information;
  } else if (min_known_features < 3) {
    reason << "min_known_features must be >= 3 (a pose has 6 DOF), got " << min_known_features;
  } else if (!(min_depth_m > 0.0)) {
    reason << "min_depth_m must be positive, got " << min_depth_m;
  } else if (!(spare_capacity >= 0.0) || !std::isfinite(spare_capacity)) {
    reason << "spare_capacity must be >= 0 and finite, got " << spare_capacity;
  } else if (max_dense_pose_dim < 0 || (max_dense_pose_dim > 0 && max_dense_pose_dim < 6)) {
    reason << "max_dense_pose_dim must be 0 (always sparse) or at least 6 (one pose), got "
           << max_dense_pose_dim;
  } else if (!(cg_tolerance > 0.0) || !std::isfinite(cg_tolerance)) {
    reason << "cg_tolerance must be positive and finite, got " << cg_tolerance;
  } else if (cg_max_iterations < 1) {
    reason << "cg_max_iterations must be >= 1, got " << cg_max_iterations;
  } else if (!(cg_flop_weight >= 0.0) || !std::isfinite(cg_flop_weight)) {
    reason << "cg_flop_weight must be >= 0 and finite, got " << cg_flop_weight;
  }
  if (why != nullptr) *why = reason.str();
  return reason.str().empty();
}

void ValidateObservations(int frame_id, const std::vector<FeatureObservation>& observations) {
  std::unordered_set<int64_t> seen;
  for (const FeatureObservation& obs : observations) {
    if (!seen.insert(obs.feature_id).second) {
      throw DataError(FrameName(frame_id) + " observes feature " + std::to_string(obs.feature_id) +
                      " twice");
    }
    if (!obs.z.allFinite() || !(obs.z.z() > 0.0)) {
      std::ostringstream msg;
      msg << FrameName(frame_id) << ": observation of feature " << obs.feature_id
          << " is not finite or has range <= 0: z = " << obs.z.transpose();
      throw DataError(msg.str());
    }
    if (!obs.Q.allFinite() || Eigen::LLT<Eigen::Matrix3d>(obs.Q).info() != Eigen::Success) {
      std::ostringstream msg;
      msg << FrameName(frame_id) << ": noise covariance Q of feature " << obs.feature_id
          << " is not positive definite:\n"
          << obs.Q;
      throw DataError(msg.str());
    }
  }
}

// One observation's contribution H^T Q^-1 H and H^T Q^-1 (z - h + H X), split into the
// blocks it touches.
struct InformationFilter::Linearization {
  struct Block {
    int64_t feature_id = -1;
    bool is_new = false;
    Eigen::Vector3d p_w = Eigen::Vector3d::Zero();  // linearisation point of the feature
    Eigen::Matrix3d I_ff = Eigen::Matrix3d::Zero();
    Eigen::Matrix<double, 6, 3> I_pf = Eigen::Matrix<double, 6, 3>::Zero();
    Eigen::Vector3d i_f = Eigen::Vector3d::Zero();
  };
  Vector6d T_w_c = Vector6d::Zero();
  Matrix6d I_pp = Matrix6d::Zero();
  Vector6d i_p = Vector6d::Zero();
  std::vector<Block> blocks;  // known features, then new ones, each in observation order
  int num_known = 0;
  int num_new = 0;
};

InformationFilter::InformationFilter(const InformationFilterOptions& options,
                                     const PinholeCamera& camera)
    : options_(options), camera_(camera), cholesky_() {
  std::string why;
  if (!options_.Check(&why)) throw ConfigError("InformationFilterOptions: " + why);
  cholesky_ = std::make_unique<SparseCholesky>(
      SparseCholeskyOptions{options_.ordering, options_.spare_capacity});
  if (options_.max_dense_pose_dim >= 6) {
    PoseSchurOptions schur_options;
    schur_options.cg_tolerance = options_.cg_tolerance;
    schur_options.cg_max_iterations = options_.cg_max_iterations;
    schur_options.cg_flop_weight = options_.cg_flop_weight;
    schur_ = std::make_unique<PoseSchurFactor>(schur_options);
  }
}

InformationFilter::~InformationFilter() = default;

InformationFilter::Linearization InformationFilter::Linearize(
    int frame_id, const Vector6d& T_w_c, const std::vector<FeatureObservation>& observations,
    int max_new_features) const {
  ValidateObservations(frame_id, observations);
  Linearization lin;
  lin.T_w_c = T_w_c;
  std::vector<Linearization::Block> new_blocks;
  for (const FeatureObservation& obs : observations) {
    Linearization::Block block;
    block.feature_id = obs.feature_id;
    block.is_new = !HasFeature(obs.feature_id);
    if (block.is_new && static_cast<int>(new_blocks.size()) >= max_new_features) continue;
    block.p_w =
        block.is_new ? ObservationToWorld(T_w_c, obs.z, camera_) : FeatureEstimate(obs.feature_id);
    const double depth = WorldToCamera(T_w_c, block.p_w).z();
    if (!(depth > options_.min_depth_m)) {
      std::ostringstream msg;
      msg << FrameName(frame_id) << ": feature " << obs.feature_id << " lies at depth " << depth
          << " m in the camera at its estimated pose; cannot linearise its observation";
      throw DataError(msg.str());
    }
    Matrix36d J_p;
    Eigen::Matrix3d J_f;
    const Eigen::Vector3d h = PredictObservation(T_w_c, block.p_w, camera_, &J_p, &J_f);
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
      new_blocks.push_back(block);
    } else {
      lin.blocks.push_back(block);
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
    for (int k = 0; k < 3; ++k) {
      matrix->StartColumn();
      for (int r = 0; r <= k; ++r) matrix->Append(offset + r, block.I_ff(r, k));
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
  if (!T_w_c.allFinite()) throw DataError(FrameName(frame_id) + ": initial pose is not finite");
  const Linearization lin = Linearize(frame_id, T_w_c, observations, INT_MAX);
  if (!anchor && lin.num_known < options_.min_known_features) {
    throw DataError(FrameName(frame_id) + " observes " + std::to_string(lin.num_known) +
                    " features already in the map; a new pose needs at least " +
                    std::to_string(options_.min_known_features));
  }

  // Keep what the update overwrites, so that a failed factorisation leaves no trace.
  const int old_dim = matrix_.dim();
  std::vector<std::pair<int, Eigen::MatrixXd>> saved_blocks;
  for (int b = 0; b < lin.num_known; ++b) {
    const int offset = feature_offset_.at(lin.blocks[b].feature_id);
    saved_blocks.emplace_back(offset, matrix_.DiagonalBlock(offset, 3));
  }
  const Eigen::VectorXd saved_info_vector = info_vector_;

  const double prior = anchor ? options_.anchor_information : 0.0;
  AppendToMatrix(lin, prior, &matrix_);
  const int new_dim = matrix_.dim();
  info_vector_.conservativeResize(new_dim);
  for (int b = 0; b < static_cast<int>(lin.blocks.size()); ++b) {
    const Linearization::Block& block = lin.blocks[b];
    const int offset =
        block.is_new ? old_dim + 3 * (b - lin.num_known) : feature_offset_.at(block.feature_id);
    if (block.is_new) info_vector_.segment<3>(offset).setZero();
    info_vector_.segment<3>(offset) += block.i_f;
  }
  info_vector_.tail<6>() = lin.i_p + prior * T_w_c;
  timings_.linearize_s = SecondsSince(start);

  // Past the dense limit the sparse factor takes over for good (its first Update refuses
  // and it factorises the whole matrix).
  if (schur_ != nullptr && 6 * (num_poses() + 1) > options_.max_dense_pose_dim) schur_.reset();
  std::vector<DiagonalIncrement> increments;
  std::vector<ObservationBlocks> schur_observations;
  for (int b = 0; b < static_cast<int>(lin.blocks.size()); ++b) {
    const Linearization::Block& block = lin.blocks[b];
    const int offset =
        block.is_new ? old_dim + 3 * (b - lin.num_known) : feature_offset_.at(block.feature_id);
    if (!block.is_new) increments.push_back({offset, block.I_ff});
    if (schur_ != nullptr) {
      schur_observations.push_back({offset, block.is_new, block.I_ff, block.I_pf});
    }
  }
  const auto restore = [&]() {
    matrix_.Truncate(old_dim);
    for (const auto& [offset, block] : saved_blocks) matrix_.SetDiagonalBlock(offset, block);
    info_vector_ = saved_info_vector;
  };
  const std::string not_positive_definite =
      "adding " + FrameName(frame_id) +
      " makes the information matrix not positive definite (degenerate observations?)";
  if (schur_ != nullptr) {
    const Matrix6d I_pp = lin.I_pp + prior * Matrix6d::Identity();
    const bool lazy = options_.iterative_recovery && !queried_;
    const SchurUpdate mode = defer_recovery_ ? SchurUpdate::kDefer
                             : lazy          ? SchurUpdate::kLazy
                                             : SchurUpdate::kExact;
    if (!schur_->AddPose(new_dim - 6, I_pp, schur_observations, mode)) {
      restore();
      throw DataError(not_positive_definite);
    }
  }
  if (defer_recovery_) {
    // The state grows by the new variables at their initial values; no factorisation
    // (the factor only notes which variables the update touched, for its next ordering).
    if (schur_ == nullptr) cholesky_->NoteUpdate(old_dim, increments);
    state_.conservativeResize(new_dim);
    for (int b = lin.num_known; b < static_cast<int>(lin.blocks.size()); ++b) {
      state_.segment<3>(old_dim + 3 * (b - lin.num_known)) = lin.blocks[b].p_w;
    }
    state_.tail<6>() = T_w_c;
    Register(lin, frame_id, old_dim, new_dim);
    recovery_pending_ = true;
    timings_.analyze_s = timings_.factorize_s = timings_.solve_s = 0.0;
    timings_.cg_iterations = 0;
    timings_.total_s = SecondsSince(start);
    return;
  }
  timings_.cg_iterations = 0;
  if (schur_ != nullptr) {
    timings_.analyze_s = 0.0;
    timings_.factorize_s = SecondsSince(start) - timings_.linearize_s;
    const auto solve_start = std::chrono::steady_clock::now();
    // Eq. 10, I X = i, from the previous estimate (only the poses are read).
    Eigen::VectorXd guess = state_;
    guess.conservativeResize(new_dim);
    guess.tail<6>() = T_w_c;
    Eigen::VectorXd solution;
    bool solved = schur_->SolveIteratively(info_vector_, guess, &solution);
    timings_.cg_iterations = schur_->last_cg_iterations();
    if (!solved && schur_->MakeExact()) {
      solution = schur_->Solve(info_vector_);
      solved = true;
    }
    if (solved) {
      queried_ = false;
      Register(lin, frame_id, old_dim, new_dim);
      state_ = std::move(solution);
      recovery_pending_ = false;
      timings_.solve_s = SecondsSince(solve_start);
      timings_.total_s = SecondsSince(start);
      return;
    }
    // S is numerically indefinite although its preconditioner was not: the sparse factor
    // takes over and decides.
    schur_.reset();
  }
  // In place when the factor has room (the re-observed features' blocks are a low-rank
  // update, the new variables new rows), else a fresh ordering and factorisation.
  if (!cholesky_->Update(matrix_, old_dim, increments) &&
      !cholesky_->Factorize(matrix_, /*pattern_changed=*/true)) {
    restore();
    // A failed in-place update leaves no factor; Factorize keeps the old one otherwise.
    // (With deferred frames pending there was no factor of the old matrix to restore.)
    if (!cholesky_->valid() && old_dim > 0 && !recovery_pending_) {
      CHECK(cholesky_->Factorize(matrix_, true)) << "the old matrix refactors";
    }
    throw DataError(not_positive_definite);
  }
  timings_.analyze_s = cholesky_->timings().analyze_s;
  timings_.factorize_s = cholesky_->timings().factorize_s;
  Register(lin, frame_id, old_dim, new_dim);

  const auto solve_start = std::chrono::steady_clock::now();
  state_ = cholesky_->Solve(info_vector_);  // eq. 10: I X = i
  recovery_pending_ = false;                // the deferred frames were factored in too
  timings_.solve_s = SecondsSince(solve_start);
  timings_.total_s = SecondsSince(start);
}

void InformationFilter::Register(const Linearization& lin, int frame_id, int old_dim, int new_dim) {
  for (int b = lin.num_known; b < static_cast<int>(lin.blocks.size()); ++b) {
    feature_offset_[lin.blocks[b].feature_id] = old_dim + 3 * (b - lin.num_known);
    feature_ids_.push_back(lin.blocks[b].feature_id);
  }
  pose_offset_[frame_id] = new_dim - 6;
  frame_ids_.push_back(frame_id);
}

void InformationFilter::Recover() {
  if (!recovery_pending_) return;
  const auto start = std::chrono::steady_clock::now();
  if (schur_ != nullptr ? !schur_->Refactor()
                        : !cholesky_->Factorize(matrix_, /*pattern_changed=*/true)) {
    throw DataError("the deferred frames (last: " + FrameName(frame_ids_.back()) +
                    ") make the information matrix not positive definite");
  }
  timings_.analyze_s = schur_ != nullptr ? 0.0 : cholesky_->timings().analyze_s;
  timings_.factorize_s = schur_ != nullptr ? SecondsSince(start) : cholesky_->timings().factorize_s;
  const auto solve_start = std::chrono::steady_clock::now();
  if (schur_ != nullptr) {
    state_ = schur_->Solve(info_vector_);
  } else {
    state_ = cholesky_->Solve(info_vector_);
  }
  recovery_pending_ = false;
  timings_.linearize_s = 0.0;
  timings_.solve_s = SecondsSince(solve_start);
  timings_.total_s = SecondsSince(start);
}

void InformationFilter::CheckRecovered() const {
  CHECK(!recovery_pending_) << "deferred updates are pending: call Recover() first";
}

void InformationFilter::EnsureExactFactor() const {
  CheckRecovered();
  if (schur_ == nullptr) return;
  const std::lock_guard<std::mutex> lock(factor_mutex_);
  CHECK(schur_->MakeExact()) << "the pose Schur complement is numerically not positive definite";
  queried_ = true;
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
  return schur_ != nullptr ? schur_->LogDet() : cholesky_->LogDet();
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
  const std::vector<int> indices = ScalarIndices(variables);
  return schur_ != nullptr ? schur_->InverseSubmatrix(indices)
                           : cholesky_->InverseSubmatrix(indices);
}

Matrix6d InformationFilter::PoseCovariance(int frame_id) const {
  return MarginalCovariance({VariableRef::Pose(frame_id)});
}

double InformationFilter::LogDetExpandedInformation(
    const Vector6d& T_w_c_candidate, const std::vector<FeatureObservation>& observations,
    int num_new_features_to_count) const {
  const int max_new = num_new_features_to_count < 0 ? INT_MAX : num_new_features_to_count;
  const Linearization lin = Linearize(-1, T_w_c_candidate, observations, max_new);
  CHECK(num_new_features_to_count < 0 || lin.num_new == num_new_features_to_count)
      << "the candidate has " << lin.num_new << " new features, asked to count "
      << num_new_features_to_count;
  UpperColumnStorage expanded = matrix_;
  AppendToMatrix(lin, 0.0, &expanded);
  SparseCholesky cholesky({options_.ordering});
  if (!cholesky.Factorize(expanded, true)) return -std::numeric_limits<double>::infinity();
  return cholesky.LogDet();
}

}  // namespace ieslam
