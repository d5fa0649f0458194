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

#include <Eigen/Cholesky>
#include <glog/logging.h>

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
  result.covariance =
      variables.empty() ? Eigen::MatrixXd(0, 0) : MarginalCovariance(variables);
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
                                          const FeatureCovariance& known,
                                          GainTerms* terms) const {
  ValidateObservations(-1, observations);
  const int num_known = static_cast<int>(observations.size()) - CountNewFeatures(observations);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * num_known, 3 * num_known);
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(3 * num_known, 6);
  Matrix6d C = Matrix6d::Zero();
  std::vector<int> in_known;  // block of each of S in known.covariance
  double new_features_term = 0.0;
  int num_counted = 0;
  for (const FeatureObservation& obs : observations) {
    const bool is_new = !HasFeature(obs.feature_id);
    if (is_new && num_new_features_to_count >= 0 && num_counted >= num_new_features_to_count) {
      continue;
    }
    const Eigen::Vector3d p_w = is_new ? ObservationToWorld(T_w_c_candidate, obs.z, camera_)
                                       : feature(obs.feature_id);
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
    A.block<3, 3>(3 * s, 3 * s) = J_f.transpose() * W * J_f;
    B.middleRows<3>(3 * s) = J_f.transpose() * W * J_p;
    C += J_p.transpose() * W * J_p;
  }
  CHECK(num_new_features_to_count < 0 || num_counted == num_new_features_to_count)
      << "the candidate has " << num_counted << " new features, asked to count "
      << num_new_features_to_count;

  const double log_det_C = LogDetSpd(C);
  if (!std::isfinite(log_det_C)) return -std::numeric_limits<double>::infinity();

  Eigen::MatrixXd P_SS(3 * num_known, 3 * num_known);
  for (int r = 0; r < num_known; ++r) {
    for (int c = 0; c < num_known; ++c) {
      P_SS.block<3, 3>(3 * r, 3 * c) =
          known.covariance.block<3, 3>(3 * in_known[r], 3 * in_known[c]);
    }
  }
  // log det(I + P (A - B C^-1 B^T)) without n x n products: with A = G G^T (3x3 blocks, each
  // feature's own information) and K = I + G^T P G,
  //   det(I + P A) = det K,   (P^-1 + A)^-1 = P - P G K^-1 G^T P   (Woodbury),
  // and the rank-6 rest by the determinant lemma:
  //   det(I + P M) = det K * det(C - N) / det C,   N = B^T (P^-1 + A)^-1 B.
  // One n x n Cholesky (K) and O(n^2) work besides.
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(3 * num_known, 3 * num_known);
  for (int s = 0; s < num_known; ++s) {
    const Eigen::LLT<Eigen::Matrix3d> block(A.block<3, 3>(3 * s, 3 * s));
    CHECK(block.info() == Eigen::Success) << "a known feature's information is not positive definite";
    G.block<3, 3>(3 * s, 3 * s) = block.matrixL();
  }
  Eigen::MatrixXd PG = Eigen::MatrixXd::Zero(3 * num_known, 3 * num_known);
  for (int s = 0; s < num_known; ++s) {
    PG.middleCols<3>(3 * s) = P_SS.middleCols<3>(3 * s) * G.block<3, 3>(3 * s, 3 * s);
  }
  Eigen::MatrixXd K = Eigen::MatrixXd::Identity(3 * num_known, 3 * num_known);
  for (int s = 0; s < num_known; ++s) {
    K.middleRows<3>(3 * s) += G.block<3, 3>(3 * s, 3 * s).transpose() * PG.middleRows<3>(3 * s);
  }
  const Eigen::LLT<Eigen::MatrixXd> K_llt(K);
  if (K_llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  const double log_det_K = 2.0 * K_llt.matrixLLT().diagonal().array().log().sum();
  const Eigen::MatrixXd PB = P_SS * B;
  const Eigen::MatrixXd GtPB = PG.transpose() * B;  // G^T P B (P symmetric)
  const Matrix6d N = B.transpose() * PB - GtPB.transpose() * K_llt.solve(GtPB);
  const Matrix6d C_minus_N = 0.5 * ((C - N) + (C - N).transpose());
  const double map_term = log_det_K + LogDetSpd(C_minus_N) - log_det_C;
  if (!std::isfinite(map_term)) return -std::numeric_limits<double>::infinity();
  if (terms != nullptr) *terms = {new_features_term, log_det_C, map_term};
  return new_features_term + log_det_C + map_term;
}

}  // namespace ieslam
