// InformationFilter's support for the information-efficient frame selection (METHOD.md §4):
// the exact gain log det I(k+1) - log det I(k) of adding a candidate, without the big
// determinant. With S the known features the candidate observes and P_SS their joint
// covariance,
//   gain = sum_new log det(J_f^T W J_f) + log det C + log det(I + P_SS (A - B C^-1 B^T)),
// A = sum J_S^T W J_S, B = sum J_S^T W J_p, C = sum J_p^T W J_p over the known features'
// observations. A new feature seen once couples to the pose only through a block that
// cancels when it is marginalised, hence its lone term.
#include <cmath>
#include <limits>
#include <sstream>

#include <glog/logging.h>
#include <Eigen/Cholesky>

#include "backend/information_filter.h"
#include "core/error.h"

namespace ieslam {

namespace {

// log det of a symmetric positive definite matrix, or -infinity if it is not one.
double LogDetSpd(const Eigen::MatrixXd& M) {
  const Eigen::LLT<Eigen::MatrixXd> llt(M);
  if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  const Eigen::VectorXd diagonal = llt.matrixLLT().diagonal();
  if (!(diagonal.minCoeff() > 0.0)) return -std::numeric_limits<double>::infinity();
  return 2.0 * diagonal.array().log().sum();
}

}  // namespace

FeatureCovariance InformationFilter::JointFeatureCovariance(
    const std::vector<int64_t>& feature_ids) const {
  FeatureCovariance result;
  std::vector<VariableRef> variables;
  for (const int64_t id : feature_ids) {
    if (!HasFeature(id) || result.index.count(id) > 0) continue;
    result.index[id] = static_cast<int>(result.feature_ids.size());
    result.feature_ids.push_back(id);
    variables.push_back(VariableRef::Feature(id));
  }
  result.covariance = variables.empty() ? Eigen::MatrixXd(0, 0) : MarginalCovariance(variables);
  return result;
}

int InformationFilter::CountNewFeatures(const std::vector<FeatureObservation>& observations) const {
  int count = 0;
  for (const FeatureObservation& obs : observations) count += HasFeature(obs.feature_id) ? 0 : 1;
  return count;
}

double InformationFilter::InformationGain(const Vector6d& T_w_c_candidate,
                                          const std::vector<FeatureObservation>& observations,
                                          int num_new_features_to_count,
                                          const FeatureCovariance& known, GainTerms* terms) const {
  ValidateObservations(-1, observations);
  const int num_known = static_cast<int>(observations.size()) - CountNewFeatures(observations);
  // Per known feature s: G_s with A_s = J_f^T W J_f = G_s G_s^T, and Bt_s = G_s^-1 B_s,
  // stored transposed in the last 6 rows of the bordered matrix factored below.
  const int n = 3 * num_known;
  std::vector<Eigen::Matrix3d> G;
  G.reserve(num_known);
  Eigen::MatrixXd bordered(n + 6, n + 6);
  Matrix6d C = Matrix6d::Zero();
  std::vector<int> in_known;  // block of each of S in known.covariance
  double new_features_term = 0.0;
  int num_counted = 0;
  for (const FeatureObservation& obs : observations) {
    const bool is_new = !HasFeature(obs.feature_id);
    if (is_new && num_new_features_to_count >= 0 && num_counted >= num_new_features_to_count) {
      continue;
    }
    const Eigen::Vector3d p_w =
        is_new ? ObservationToWorld(T_w_c_candidate, obs.z, camera_) : feature(obs.feature_id);
    const double depth = WorldToCamera(T_w_c_candidate, p_w).z();
    if (!(depth > options_.min_depth_m)) {
      std::ostringstream msg;
      msg << "candidate frame: feature " << obs.feature_id << " lies at depth " << depth
          << " m in the camera at the candidate pose; cannot linearise its observation";
      throw DataError(msg.str());
    }
    Matrix36d J_p;
    Eigen::Matrix3d J_f;
    PredictObservation(T_w_c_candidate, p_w, camera_, &J_p, &J_f);
    const Eigen::Matrix3d W = obs.Q.inverse();
    if (is_new) {
      new_features_term += LogDetSpd(J_f.transpose() * W * J_f);
      ++num_counted;
      continue;
    }
    const auto it = known.index.find(obs.feature_id);
    CHECK(it != known.index.end())
        << "feature " << obs.feature_id << " is missing from the FeatureCovariance";
    const int s = static_cast<int>(in_known.size());
    in_known.push_back(it->second);
    const Eigen::LLT<Eigen::Matrix3d> A_s(J_f.transpose() * W * J_f);
    CHECK(A_s.info() == Eigen::Success) << "a known feature's information is not positive definite";
    G.push_back(A_s.matrixL());
    bordered.block<6, 3>(n, 3 * s) = A_s.matrixL().solve(J_f.transpose() * W * J_p).transpose();
    C += J_p.transpose() * W * J_p;
  }
  CHECK(num_new_features_to_count < 0 || num_counted == num_new_features_to_count)
      << "the candidate has " << num_counted << " new features, asked to count "
      << num_new_features_to_count;

  const double log_det_C = LogDetSpd(C);
  if (!std::isfinite(log_det_C)) return -std::numeric_limits<double>::infinity();

  // log det(I + P (A - B C^-1 B^T)) without n x n products. With A = G G^T (3x3 blocks) and
  // Bt = G^-1 B, the matrix determinant lemma and Woodbury's identity give
  //   det(I + P M) = det K * det(C - N) / det C,   K = I + G^T P G,
  //   N = B^T (P^-1 + A)^-1 B = Bt^T (I - K^-1) Bt,
  // and as each J_f is square and invertible ((u, v, d) of a 3-D point: 3x3; A_s's Cholesky
  // above checks it), C = Bt^T Bt, so C - N = Bt^T K^-1 Bt = Y^T Y
  // with Y = L_K^-1 Bt. One Cholesky of the bordered matrix [K, Bt; Bt^T, 2C] gives both:
  // its factor is [L_K, 0; Y^T, L_2], and 2C - Y^T Y >= C > 0 keeps it positive definite.
  // K is formed block by block from P, lower half only (all LLT reads; the strict upper part
  // of `bordered` is never written, so only its lower factor may be used), factored in place.
  for (int s = 0; s < num_known; ++s) {
    for (int r = s; r < num_known; ++r) {
      bordered.block<3, 3>(3 * r, 3 * s).noalias() =
          G[r].transpose() * known.covariance.block<3, 3>(3 * in_known[r], 3 * in_known[s]) * G[s];
    }
  }
  bordered.diagonal().head(n).array() += 1.0;
  bordered.bottomRightCorner<6, 6>() = 2.0 * C;
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(bordered);
  if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  const double log_det_K = 2.0 * bordered.diagonal().head(n).array().log().sum();
  const auto Y_transpose = bordered.bottomLeftCorner(6, n);
  const Matrix6d C_minus_N = Y_transpose * Y_transpose.transpose();
  const double map_term = log_det_K + LogDetSpd(C_minus_N) - log_det_C;
  if (!std::isfinite(map_term)) return -std::numeric_limits<double>::infinity();
  if (terms != nullptr) *terms = {new_features_term, log_det_C, map_term};
  return new_features_term + log_det_C + map_term;
}

}  // namespace ieslam
