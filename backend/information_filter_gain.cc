// InformationFilter's information gain of a candidate frame (Zhou et al. 2008, §V-A), without
// the expanded matrix, and the covariance it is computed from.
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>
#include <vector>

#include <glog/logging.h>
#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "backend/information_filter.h"

namespace ieslam {

namespace {

constexpr double kMinusInfinity = -std::numeric_limits<double>::infinity();

// log det of a symmetric positive definite matrix, or -infinity if it is not one.
double LogDetSpd(const Eigen::MatrixXd& M) {
  const Eigen::LLT<Eigen::MatrixXd> llt(M);
  if (llt.info() != Eigen::Success) return kMinusInfinity;
  const Eigen::VectorXd diagonal = llt.matrixLLT().diagonal();
  if (!(diagonal.minCoeff() > 0.0)) return kMinusInfinity;
  return 2.0 * diagonal.array().log().sum();
}

// What an entering feature's sightings add once the feature is eliminated, as the columns of
// a square root Z = [G; H] of it: G (6k x 3k) on the k earlier poses, H (6 x 3k) on the new
// pose. Of the 3(k + 1) whitened rows, the feature takes 3 (its block F = J_f^T J_f, with
// log det F its own term); the other 3k constrain the poses.
struct SightingColumns {
  std::vector<int> rows;  // first row of each earlier pose's block in the FeatureCovariance
  Eigen::MatrixXd G;
  Eigen::MatrixXd H;
};

// From the whitened Jacobians of all sightings (rows; J_poses' last 6 columns the new pose's):
// with J_f = Q R, the rows orthogonal to J_f's columns, Q_2^T J_poses, are what the poses
// keep. False when J_f has no full rank.
bool EliminateFeature(const Eigen::MatrixXd& J_f, const Eigen::MatrixXd& J_poses,
                      SightingColumns* columns, double* log_det_F) {
  const int rows = static_cast<int>(J_f.rows()), k3 = rows - 3;
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(J_f);
  const Eigen::Vector3d R_diagonal = qr.matrixQR().diagonal().head<3>().cwiseAbs();
  if (!(R_diagonal.minCoeff() > 0.0)) return false;
  *log_det_F = 2.0 * R_diagonal.array().log().sum();
  const Eigen::MatrixXd Q = qr.householderQ();
  const Eigen::MatrixXd Z_transpose = Q.rightCols(k3).transpose() * J_poses;
  columns->G = Z_transpose.leftCols(J_poses.cols() - 6).transpose();
  columns->H = Z_transpose.rightCols<6>().transpose();
  return true;
}

// The covariance of the earlier poses of `a` (rows) and the rows `rows_b` (6 each).
Eigen::MatrixXd PoseCovarianceBlock(const FeatureCovariance& known, const std::vector<int>& rows_a,
                                    const std::vector<int>& rows_b) {
  Eigen::MatrixXd P(6 * rows_a.size(), 6 * rows_b.size());
  for (size_t i = 0; i < rows_a.size(); ++i) {
    for (size_t j = 0; j < rows_b.size(); ++j) {
      P.block<6, 6>(6 * i, 6 * j) = known.covariance.block<6, 6>(rows_a[i], rows_b[j]);
    }
  }
  return P;
}

// The gain's map term log det(I + P (A - B C^-1 B^T)) from the square root Z = [G; H] of the
// update the candidate makes on the map's variables V (the known features it observes, and
// the earlier poses of the entering features) and the new pose, once the entering features
// are eliminated: A = G G^T, B = G H^T, C = H H^T. `bordered`'s last 6 rows hold H, and P is
// `known`'s covariance of V; -infinity if the term is not finite.
//
// A known feature's block of G is the Cholesky factor G_s of A_s = J_f^T W J_f, its block of
// H Bt_s^T = (G_s^-1 B_s)^T; an entering feature's are its SightingColumns. Without n x n
// products: the matrix determinant lemma and Woodbury's identity give
//   det(I + P M) = det K * det(C - N) / det C,   K = I + G^T P G,
//   N = B^T (P^-1 + A)^-1 B = H (I - K^-1) H^T,
// and C = H H^T, so C - N = H K^-1 H^T = Y^T Y with Y = L_K^-1 H^T. One Cholesky of the
// bordered matrix [K, H^T; H, 2C] gives both: its factor is [L_K, 0; Y^T, L_2], and
// 2C - Y^T Y >= C > 0 keeps it positive definite. K is formed block by block from P, lower
// half only (all LLT reads; the strict upper part of `bordered` is never written, so only
// its lower factor may be used), factored in place.
double MapTerm(const std::vector<Eigen::Matrix3d>& G, const std::vector<int>& in_known,
               const std::vector<SightingColumns>& sightings, const FeatureCovariance& known,
               const Matrix6d& C, double log_det_C, Eigen::MatrixXd* bordered_matrix) {
  Eigen::MatrixXd& bordered = *bordered_matrix;
  const int num_known = static_cast<int>(G.size());
  for (int s = 0; s < num_known; ++s) {
    for (int r = s; r < num_known; ++r) {
      bordered.block<3, 3>(3 * r, 3 * s).noalias() =
          G[r].transpose() * known.covariance.block<3, 3>(3 * in_known[r], 3 * in_known[s]) * G[s];
    }
  }
  int row = 3 * num_known;
  for (size_t a = 0; a < sightings.size(); ++a) {
    const SightingColumns& A = sightings[a];
    const int width = static_cast<int>(A.G.cols());
    for (int s = 0; s < num_known; ++s) {
      Eigen::MatrixXd P_as(A.G.rows(), 3);
      for (size_t i = 0; i < A.rows.size(); ++i) {
        P_as.middleRows<6>(6 * i) = known.covariance.block<6, 3>(A.rows[i], 3 * in_known[s]);
      }
      bordered.block(row, 3 * s, width, 3).noalias() = A.G.transpose() * P_as * G[s];
    }
    int col = 3 * num_known;
    for (size_t b = 0; b <= a; ++b) {
      const SightingColumns& B = sightings[b];
      bordered.block(row, col, width, B.G.cols()).noalias() =
          A.G.transpose() * PoseCovarianceBlock(known, A.rows, B.rows) * B.G;
      col += static_cast<int>(B.G.cols());
    }
    row += width;
  }
  const int n = row;
  bordered.diagonal().head(n).array() += 1.0;
  bordered.bottomRightCorner<6, 6>() = 2.0 * C;
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(bordered);
  if (llt.info() != Eigen::Success) return kMinusInfinity;
  const double log_det_K = 2.0 * bordered.diagonal().head(n).array().log().sum();
  const auto Y_transpose = bordered.bottomLeftCorner(6, n);
  const Matrix6d C_minus_N = Y_transpose * Y_transpose.transpose();
  const double map_term = log_det_K + LogDetSpd(C_minus_N) - log_det_C;
  if (!std::isfinite(map_term)) return kMinusInfinity;
  return map_term;
}

// The blocks a candidate's observations give the gain (InformationFilter::InformationGain).
struct GainBlocks {
  // Per known feature s: G_s with A_s = J_f^T W J_f = G_s G_s^T, and Bt_s = G_s^-1 B_s.
  std::vector<Eigen::Matrix3d> G;
  std::vector<Eigen::Matrix<double, 6, 3>> Bt_transposed;
  std::vector<SightingColumns> sightings;
  Matrix6d C = Matrix6d::Zero();
  std::vector<int> in_known;  // block of each of S in known.covariance
  double new_features_term = 0.0;
  // The terms as the filter holding every feature since its first sighting sees them
  // (GainTerms): the entering pending features' first sightings' own blocks (which that
  // filter holds already), the own blocks of the features entering at their first sighting
  // and of those that wait aside, and the pose's information with the pending ones known.
  double first_sightings_term = 0.0, lone_terms = 0.0, waiting_terms = 0.0;
  Matrix6d C_with_pending = Matrix6d::Zero();
};

// The gain from its blocks: log det C and the map term, and the terms into *terms.
double CombineGain(const GainBlocks& b, const FeatureCovariance& known, GainTerms* terms) {
  const double log_det_C = LogDetSpd(b.C);
  if (!std::isfinite(log_det_C)) return kMinusInfinity;
  int n = 3 * static_cast<int>(b.G.size());
  for (const SightingColumns& columns : b.sightings) n += static_cast<int>(columns.G.cols());
  Eigen::MatrixXd bordered(n + 6, n + 6);
  for (size_t s = 0; s < b.G.size(); ++s) bordered.block<6, 3>(n, 3 * s) = b.Bt_transposed[s];
  int col = 3 * static_cast<int>(b.G.size());
  for (const SightingColumns& columns : b.sightings) {
    bordered.block(n, col, 6, columns.H.cols()) = columns.H;
    col += static_cast<int>(columns.H.cols());
  }
  const double map_term = MapTerm(b.G, b.in_known, b.sightings, known, b.C, log_det_C, &bordered);
  if (!std::isfinite(map_term)) return kMinusInfinity;
  const double gain = b.new_features_term + log_det_C + map_term;
  if (terms == nullptr) return gain;
  // Without entering pending features the pose and map terms are this filter's own.
  const double pose_term = b.sightings.empty() ? log_det_C : LogDetSpd(b.C_with_pending);
  if (!std::isfinite(pose_term)) return kMinusInfinity;
  terms->new_features = b.lone_terms + b.waiting_terms;
  terms->pose = pose_term;
  terms->map =
      b.sightings.empty() ? map_term : gain - (b.lone_terms + b.first_sightings_term) - pose_term;
  return gain;
}

}  // namespace

namespace {

// A pending feature p = g(x, z) of its first sighting z from pose x, linearised there:
// h(x, p) = z gives dp = J_f^-1 dz - J_f^-1 J_p dx, so p's covariance is G_x P_xx G_x^T +
// G_z Q G_z^T and its covariance with any other variable v is G_x P_xv.
struct PendingPlacement {
  int64_t id = -1;
  int frame = -1;
  Matrix36d G_x = Matrix36d::Zero();
  Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();  // G_z Q G_z^T
};

// The covariance of [known features; pending features; poses] from M, that of [known features
// (nk rows); poses], where pose_row is each pose's row in the result.
Eigen::MatrixXd WithPendingFeatures(const Eigen::MatrixXd& M, int nk,
                                    const std::vector<PendingPlacement>& pending,
                                    const std::unordered_map<int, int>& pose_row) {
  const int np = 3 * static_cast<int>(pending.size());
  const int nx = static_cast<int>(M.rows()) - nk;
  const auto row_in_M = [&](int frame) { return pose_row.at(frame) - np; };
  Eigen::MatrixXd C(nk + np + nx, nk + np + nx);
  C.topLeftCorner(nk, nk) = M.topLeftCorner(nk, nk);
  C.topRightCorner(nk, nx) = M.topRightCorner(nk, nx);
  C.bottomLeftCorner(nx, nk) = M.bottomLeftCorner(nx, nk);
  C.bottomRightCorner(nx, nx) = M.bottomRightCorner(nx, nx);
  // Each pending feature's rows: G_x times its pose's rows of M.
  Eigen::MatrixXd R(np, M.cols());
  for (size_t j = 0; j < pending.size(); ++j) {
    R.middleRows<3>(3 * j).noalias() = pending[j].G_x * M.middleRows<6>(row_in_M(pending[j].frame));
  }
  C.block(nk, 0, np, nk) = R.leftCols(nk);
  C.block(nk, nk + np, np, nx) = R.rightCols(nx);
  C.block(0, nk, nk, np) = C.block(nk, 0, np, nk).transpose();
  C.block(nk + np, nk, nx, np) = C.block(nk, nk + np, np, nx).transpose();
  for (size_t i = 0; i < pending.size(); ++i) {
    for (size_t j = 0; j <= i; ++j) {
      Eigen::Matrix3d block =
          R.block<3, 6>(3 * i, row_in_M(pending[j].frame)) * pending[j].G_x.transpose();
      if (i == j) block += pending[i].noise;
      C.block<3, 3>(nk + 3 * i, nk + 3 * j) = block;
      C.block<3, 3>(nk + 3 * j, nk + 3 * i) = block.transpose();
    }
  }
  return C;
}

}  // namespace

FeatureCovariance InformationFilter::JointFeatureCovariance(
    const std::vector<int64_t>& feature_ids, const std::vector<int>& frame_ids) const {
  FeatureCovariance result;
  std::vector<VariableRef> variables;
  std::vector<PendingPlacement> pending;
  std::unordered_set<int64_t> placed;
  for (const int64_t id : feature_ids) {
    if (result.index.count(id) > 0 || placed.count(id) > 0) continue;
    if (HasFeature(id)) {
      result.index[id] = static_cast<int>(result.feature_ids.size());
      result.feature_ids.push_back(id);
      variables.push_back(VariableRef::Feature(id));
      continue;
    }
    const std::vector<FeatureSighting>* sightings = PendingSightings(id);
    if (sightings == nullptr) continue;
    const FeatureSighting& first = sightings->front();
    const Vector6d T_w_c = state_.segment<6>(pose_offset_.at(first.frame_id));
    ObservationJacobians jacobians;
    if (!LinearizeAt(T_w_c, MapFeature(id), &jacobians)) continue;
    const Eigen::Matrix3d J_f_inverse = jacobians.J_f.inverse();
    if (!J_f_inverse.allFinite()) continue;
    PendingPlacement p;
    p.id = id;
    p.frame = first.frame_id;
    p.G_x = -J_f_inverse * jacobians.J_p;
    p.noise = J_f_inverse * first.observation.Q * J_f_inverse.transpose();
    pending.push_back(p);
    placed.insert(id);
  }
  const int num_known = static_cast<int>(result.feature_ids.size());
  for (const PendingPlacement& p : pending) {
    result.index[p.id] = static_cast<int>(result.feature_ids.size());
    result.feature_ids.push_back(p.id);
  }
  std::vector<int> frames = frame_ids;
  for (const PendingPlacement& p : pending) frames.push_back(p.frame);
  int row = 3 * static_cast<int>(result.feature_ids.size());
  for (const int frame : frames) {
    if (result.pose_row.count(frame) > 0) continue;
    result.pose_row[frame] = row;
    row += 6;
    result.frame_ids.push_back(frame);
    variables.push_back(VariableRef::Pose(frame));
  }
  if (variables.empty()) {
    result.covariance = Eigen::MatrixXd(0, 0);
    return result;
  }
  // The known features and the poses, as MarginalCovariance orders them.
  const Eigen::MatrixXd M = MarginalCovariance(variables);
  if (pending.empty()) {
    result.covariance = M;
    return result;
  }
  result.covariance = WithPendingFeatures(M, 3 * num_known, pending, result.pose_row);
  return result;
}

Eigen::Vector3d InformationFilter::MapFeature(int64_t feature_id) const {
  if (HasFeature(feature_id)) return feature(feature_id);
  const std::vector<FeatureSighting>* sightings = PendingSightings(feature_id);
  CHECK(sightings != nullptr) << "feature " << feature_id << " is neither known nor pending";
  const FeatureSighting& first = sightings->front();
  return ObservationToWorld(state_.segment<6>(pose_offset_.at(first.frame_id)), first.observation.z,
                            camera_);
}

int InformationFilter::CountFirstSightings(
    const std::vector<FeatureObservation>& observations) const {
  int count = 0;
  for (const FeatureObservation& obs : observations) {
    count += HasFeature(obs.feature_id) || IsPending(obs.feature_id) ? 0 : 1;
  }
  return count;
}

int InformationFilter::CountEnteringFeatures(
    const std::vector<FeatureObservation>& observations) const {
  int count = 0;
  for (const FeatureObservation& obs : observations) count += Enters(obs.feature_id) ? 1 : 0;
  return count;
}

std::vector<int> InformationFilter::EarlierSightingFrames(
    const std::vector<FeatureObservation>& observations) const {
  std::vector<int> frames;
  for (const FeatureObservation& obs : observations) {
    const std::vector<FeatureSighting>* sightings = PendingSightings(obs.feature_id);
    if (sightings == nullptr || !Enters(obs.feature_id)) continue;
    for (const FeatureSighting& sighting : *sightings) frames.push_back(sighting.frame_id);
  }
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  return frames;
}

bool InformationFilter::WhitenedEarlierSightings(const std::vector<FeatureSighting>& sightings,
                                                 const Eigen::Vector3d& p_w, Eigen::MatrixXd* J_f,
                                                 Eigen::MatrixXd* J_c) const {
  const int k = static_cast<int>(sightings.size());
  J_f->setZero(3 * k, 3);
  J_c->setZero(3 * k, 6 * k);
  for (int j = 0; j < k; ++j) {
    const FeatureSighting& sighting = sightings[j];
    ObservationJacobians jacobians;
    const Vector6d T_w_c = state_.segment<6>(pose_offset_.at(sighting.frame_id));
    if (!LinearizeAt(T_w_c, p_w, &jacobians)) return false;
    const Eigen::Matrix3d U =
        Eigen::LLT<Eigen::Matrix3d>(sighting.observation.Q.inverse()).matrixU();
    J_f->block<3, 3>(3 * j, 0) = U * jacobians.J_f;
    J_c->block<3, 6>(3 * j, 6 * j) = U * jacobians.J_p;
  }
  return true;
}

// The exact gain of adding the candidate, without the expanded matrix (§V-A). With V the
// map's variables the candidate's observations reach (the known features S it observes; with
// delayed initialisation also the poses that saw the pending features it completes) and P
// their joint covariance,
//   gain = sum_entering log det F_f + log det C + log det(I + P (A - B C^-1 B^T)),
// A, B, C the update's blocks on V and the new pose once the entering features are
// eliminated (MapTerm). A feature entering at its first sighting couples to the pose only
// through a block that cancels when it is marginalised, hence its lone term
// log det(J_f^T W J_f); one entering on a later sighting ties its earlier poses to the new one.
// A first sighting that leaves its feature pending adds nothing to the state, and its lone
// term to the terms (GainTerms).
double InformationFilter::InformationGain(const Vector6d& T_w_c_candidate,
                                          const std::vector<FeatureObservation>& observations,
                                          int num_first_sightings_to_count,
                                          const FeatureCovariance& known, GainTerms* terms) const {
  CheckRecovered();
  if (!ObservationsProblem(-1, observations).empty()) return kMinusInfinity;
  GainBlocks b;
  int num_first = 0;
  for (const FeatureObservation& obs : observations) {
    const bool is_new = !HasFeature(obs.feature_id);
    const std::vector<FeatureSighting>* earlier =
        is_new ? PendingSightings(obs.feature_id) : nullptr;
    if (is_new && earlier == nullptr) {
      if (num_first_sightings_to_count >= 0 && num_first >= num_first_sightings_to_count) {
        continue;
      }
      ++num_first;
      ObservationJacobians jacobians;
      if (!LinearizeObservation(T_w_c_candidate, obs, &jacobians)) return kMinusInfinity;
      const double lone = LogDetSpd(jacobians.J_f.transpose() * obs.Q.inverse() * jacobians.J_f);
      const bool enters = Enters(obs.feature_id);
      (enters ? b.lone_terms : b.waiting_terms) += lone;
      if (enters) b.new_features_term += lone;
      continue;
    }
    if (is_new && !Enters(obs.feature_id)) continue;
    ObservationJacobians jacobians;
    if (!LinearizeObservation(T_w_c_candidate, obs, &jacobians)) return kMinusInfinity;
    const Matrix36d& J_p = jacobians.J_p;
    const Eigen::Matrix3d& J_f = jacobians.J_f;
    const Eigen::Matrix3d W = obs.Q.inverse();
    if (is_new) {
      const int k = static_cast<int>(earlier->size());
      Eigen::MatrixXd J_f_all, J_c;
      if (!WhitenedEarlierSightings(*earlier, jacobians.p_w, &J_f_all, &J_c)) return kMinusInfinity;
      const Eigen::Matrix3d U = Eigen::LLT<Eigen::Matrix3d>(W).matrixU();
      J_f_all.conservativeResize(3 * k + 3, 3);
      J_f_all.bottomRows<3>() = U * J_f;
      Eigen::MatrixXd J_poses = Eigen::MatrixXd::Zero(3 * k + 3, 6 * k + 6);
      J_poses.topLeftCorner(3 * k, 6 * k) = J_c;
      J_poses.bottomRightCorner<3, 6>() = U * J_p;
      SightingColumns columns;
      double log_det_F = 0.0;
      if (!EliminateFeature(J_f_all, J_poses, &columns, &log_det_F)) return kMinusInfinity;
      for (int j = 0; j < k; ++j) {
        const auto U_J_f = J_f_all.middleRows<3>(3 * j);
        b.first_sightings_term += LogDetSpd(U_J_f.transpose() * U_J_f);
      }
      b.C_with_pending += J_p.transpose() * W * J_p;
      for (const FeatureSighting& sighting : *earlier) {
        const auto it = known.pose_row.find(sighting.frame_id);
        CHECK(it != known.pose_row.end())
            << "pose " << sighting.frame_id << " is missing from the FeatureCovariance";
        columns.rows.push_back(it->second);
      }
      b.new_features_term += log_det_F;
      b.C += columns.H * columns.H.transpose();
      b.sightings.push_back(std::move(columns));
      continue;
    }
    const auto it = known.index.find(obs.feature_id);
    CHECK(it != known.index.end())
        << "feature " << obs.feature_id << " is missing from the FeatureCovariance";
    b.in_known.push_back(it->second);
    const Eigen::LLT<Eigen::Matrix3d> A_s(J_f.transpose() * W * J_f);
    CHECK(A_s.info() == Eigen::Success) << "a known feature's information is not positive definite";
    b.G.push_back(A_s.matrixL());
    b.Bt_transposed.push_back(A_s.matrixL().solve(J_f.transpose() * W * J_p).transpose());
    const Matrix6d C_s = J_p.transpose() * W * J_p;
    b.C += C_s;
    b.C_with_pending += C_s;
  }
  CHECK(num_first_sightings_to_count < 0 || num_first == num_first_sightings_to_count)
      << "the candidate has " << num_first << " first sightings, asked to count "
      << num_first_sightings_to_count;

  return CombineGain(b, known, terms);
}

}  // namespace ieslam
