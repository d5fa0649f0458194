// A dense EIF used only by tests as the reference for the sparse InformationFilter:
// the paper's eqs. 9-10 written as plainly as possible, with full Jacobian rows H over the
// whole state and dense Eigen algebra. Its variable order (each pose, then its new
// features) differs from the sparse filter's on purpose; compare through the ids.
//
// With min_sightings 2 (delayed initialisation) a feature's first sighting waits aside; at
// its second the feature is initialised from the first (back-projected from that pose's
// estimate) and both sightings are added as rows linearised at X(k), as any other.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>

#include "core/camera.h"
#include "core/observation.h"
#include "core/pose.h"

namespace ieslam {
namespace testing {

class DenseReferenceFilter {
 public:
  DenseReferenceFilter(double anchor_information, const PinholeCamera& camera,
                       int min_sightings = 1)
      : anchor_(anchor_information), camera_(camera), min_sightings_(min_sightings) {}
  DenseReferenceFilter(const DenseReferenceFilter&) = delete;
  DenseReferenceFilter& operator=(const DenseReferenceFilter&) = delete;

  void AddFirstPose(int frame_id, const Vector6d& T_w_c,
                    const std::vector<FeatureObservation>& observations) {
    Add(frame_id, T_w_c, observations, true);
  }
  void AddPose(int frame_id, const Vector6d& T_w_c,
               const std::vector<FeatureObservation>& observations) {
    Add(frame_id, T_w_c, observations, false);
  }

  Vector6d pose(int frame_id) const { return X_.segment<6>(poses_.at(frame_id)); }
  Eigen::Vector3d feature(int64_t id) const { return X_.segment<3>(features_.at(id)); }
  bool HasFeature(int64_t id) const { return features_.count(id) > 0; }
  int num_pending() const { return static_cast<int>(pending_.size()); }
  int state_dim() const { return static_cast<int>(X_.size()); }
  const Eigen::MatrixXd& information() const { return I_; }
  int PoseIndex(int frame_id) const { return poses_.at(frame_id); }
  int FeatureIndex(int64_t id) const { return features_.at(id); }

  double LogDetInformation() const { return LogDet(I_); }

  // Rows/columns `indices` of the explicit inverse.
  Eigen::MatrixXd CovarianceOf(const std::vector<int>& indices) const {
    const Eigen::MatrixXd P = I_.inverse();
    Eigen::MatrixXd result(indices.size(), indices.size());
    for (size_t r = 0; r < indices.size(); ++r) {
      for (size_t c = 0; c < indices.size(); ++c) result(r, c) = P(indices[r], indices[c]);
    }
    return result;
  }

  // The paper's gain: log det of the explicitly expanded matrix, of the candidate's features
  // that no pose has seen the first `num_first` counted (a negative value counts all), and
  // every pending feature it brings in (with its earlier sightings); sightings that leave a
  // feature pending add nothing.
  double LogDetExpanded(const Vector6d& T_w_c, const std::vector<FeatureObservation>& observations,
                        int num_first) const {
    Eigen::MatrixXd I = I_;
    Eigen::VectorXd X = X_;
    std::map<int64_t, int> features = features_;
    const int pose_index = Grow(&I, &X, T_w_c);
    int counted = 0;
    for (const FeatureObservation& obs : observations) {
      if (features.count(obs.feature_id) == 0) {
        if (!Enters(obs.feature_id)) continue;
        if (Sightings(obs.feature_id).empty()) {
          if (counted == num_first) continue;
          ++counted;
        }
        features[obs.feature_id] = Grow(&I, &X, InitialPoint(X, T_w_c, obs));
        for (const auto& [frame, earlier] : Sightings(obs.feature_id)) {
          Eigen::MatrixXd H;
          Row(X, poses_.at(frame), features.at(obs.feature_id), &H);
          I += H.transpose() * earlier.Q.inverse() * H;
        }
      }
      Eigen::MatrixXd H;
      Row(X, pose_index, features.at(obs.feature_id), &H);
      I += H.transpose() * obs.Q.inverse() * H;
    }
    return LogDet(I);
  }

 private:
  static double LogDet(const Eigen::MatrixXd& M) {
    const Eigen::LLT<Eigen::MatrixXd> llt(M);
    return 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  }

  // Appends a variable initialised to `value` with zero information; returns its index.
  static int Grow(Eigen::MatrixXd* I, Eigen::VectorXd* X, const Eigen::VectorXd& value) {
    const int index = static_cast<int>(X->size());
    const int n = index + static_cast<int>(value.size());
    I->conservativeResize(n, n);
    I->rightCols(value.size()).setZero();
    I->bottomRows(value.size()).setZero();
    X->conservativeResize(n);
    X->tail(value.size()) = value;
    return index;
  }

  // z = h(X) and the full-width Jacobian row block H of one observation.
  Eigen::Vector3d Row(const Eigen::VectorXd& X, int pose_index, int feature_index,
                      Eigen::MatrixXd* H) const {
    Matrix36d J_p;
    Eigen::Matrix3d J_f;
    const Eigen::Vector3d h = PredictObservation(X.segment<6>(pose_index),
                                                 X.segment<3>(feature_index), camera_, &J_p, &J_f);
    *H = Eigen::MatrixXd::Zero(3, X.size());
    H->middleCols<6>(pose_index) = J_p;
    H->middleCols<3>(feature_index) = J_f;
    return h;
  }

  using Sighting = std::pair<int, FeatureObservation>;  // (frame, observation)

  bool Enters(int64_t id) const {
    const auto it = pending_.find(id);
    return (it == pending_.end() ? 0 : static_cast<int>(it->second.size())) + 1 >= min_sightings_;
  }
  std::vector<Sighting> Sightings(int64_t id) const {
    const auto it = pending_.find(id);
    return it == pending_.end() ? std::vector<Sighting>() : it->second;
  }
  // An entering feature's initial value: its first sighting back-projected from that pose's
  // estimate in X, or from T_w_c when this is its first.
  Eigen::Vector3d InitialPoint(const Eigen::VectorXd& X, const Vector6d& T_w_c,
                               const FeatureObservation& obs) const {
    const std::vector<Sighting> earlier = Sightings(obs.feature_id);
    if (earlier.empty()) return ObservationToWorld(T_w_c, obs.z, camera_);
    return ObservationToWorld(X.segment<6>(poses_.at(earlier.front().first)),
                              earlier.front().second.z, camera_);
  }

  void Add(int frame_id, const Vector6d& T_w_c, const std::vector<FeatureObservation>& observations,
           bool anchor) {
    const Eigen::VectorXd X_before = X_;
    const int pose_index = Grow(&I_, &X_, T_w_c);
    i_.conservativeResize(X_.size());
    i_.tail<6>().setZero();
    poses_[frame_id] = pose_index;
    if (anchor) {
      I_.block<6, 6>(pose_index, pose_index) += anchor_ * Matrix6d::Identity();
      i_.tail<6>() += anchor_ * T_w_c;
    }
    // (pose index, observation): the rows of this update.
    std::vector<std::pair<int, FeatureObservation>> rows;
    std::vector<FeatureObservation> deferred;
    for (const FeatureObservation& obs : observations) {
      if (!HasFeature(obs.feature_id)) {
        if (!Enters(obs.feature_id)) {
          deferred.push_back(obs);
          continue;
        }
        features_[obs.feature_id] = Grow(&I_, &X_, InitialPoint(X_before, T_w_c, obs));
        i_.conservativeResize(X_.size());
        i_.tail<3>().setZero();
        for (const auto& [frame, earlier] : Sightings(obs.feature_id)) {
          rows.emplace_back(poses_.at(frame), earlier);
        }
        pending_.erase(obs.feature_id);
      }
      rows.emplace_back(pose_index, obs);
    }
    for (const FeatureObservation& obs : deferred)
      pending_[obs.feature_id].emplace_back(frame_id, obs);
    // Eq. 9 at X(k): every observation linearised at the estimate before this update.
    const Eigen::VectorXd X_k = X_;
    for (const auto& [pose, obs] : rows) {
      Eigen::MatrixXd H;
      const Eigen::Vector3d h = Row(X_k, pose, features_.at(obs.feature_id), &H);
      const Eigen::Matrix3d W = obs.Q.inverse();
      I_ += H.transpose() * W * H;
      i_ += H.transpose() * W * (obs.z - h + H * X_k);
    }
    X_ = I_.ldlt().solve(i_);  // eq. 10
  }

  double anchor_;
  PinholeCamera camera_;
  int min_sightings_ = 1;
  std::map<int64_t, std::vector<Sighting>> pending_;
  Eigen::MatrixXd I_;
  Eigen::VectorXd i_;
  Eigen::VectorXd X_;
  std::map<int, int> poses_;
  std::map<int64_t, int> features_;
};

}  // namespace testing
}  // namespace ieslam
