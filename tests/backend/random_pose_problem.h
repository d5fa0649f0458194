// A random problem in information form laid out as the filter lays it out (each pose after
// its new features), for the tests of the pose Schur factor and its pieces. The trajectory
// goes out and comes back twice, so that later poses re-observe features of poses long
// left: a factor's window has to evict poses and move them back in. `I` mirrors every
// addition densely.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "backend/information_factor.h"
#include "backend/upper_column_storage.h"

namespace ieslam {
namespace testing {

// One pose as the filter hands it to a factor.
struct PoseAddition {
  int pose_offset = 0;
  Eigen::Matrix<double, 6, 6> I_pp = Eigen::Matrix<double, 6, 6>::Zero();
  std::vector<ObservationBlocks> observations;
};

// The update `a` brings to a factor of the matrix.
inline InformationUpdate UpdateOf(const PoseAddition& a) {
  InformationUpdate update;
  update.old_dim = a.pose_offset;
  for (const ObservationBlocks& obs : a.observations) update.old_dim -= obs.is_new ? 3 : 0;
  update.pose_block = a.I_pp;
  update.observations = a.observations;
  return update;
}

// Appends `a` to `matrix` as the filter does: the new features' columns, then the pose's
// (its couplings in them), and the re-observed features' blocks added.
inline void AppendToMatrix(const PoseAddition& a, UpperColumnStorage* matrix) {
  std::vector<const ObservationBlocks*> sorted;  // by feature offset
  for (const ObservationBlocks& obs : a.observations) sorted.push_back(&obs);
  std::sort(sorted.begin(), sorted.end(),
            [](const auto* x, const auto* y) { return x->feature_offset < y->feature_offset; });
  for (const ObservationBlocks* obs : sorted) {
    if (!obs->is_new) {
      matrix->AddToDiagonalBlock(obs->feature_offset, obs->I_ff);
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      matrix->StartColumn();
      for (int r = 0; r <= k; ++r) matrix->Append(obs->feature_offset + r, obs->I_ff(r, k));
    }
  }
  for (int k = 0; k < 6; ++k) {
    matrix->StartColumn();
    for (const ObservationBlocks* obs : sorted) {
      for (int r = 0; r < 3; ++r) matrix->Append(obs->feature_offset + r, obs->I_pf(k, r));
    }
    for (int r = 0; r <= k; ++r) matrix->Append(a.pose_offset + r, a.I_pp(r, k));
  }
}

struct RandomPoseProblem {
  explicit RandomPoseProblem(unsigned seed) : rng(seed) {}

  // Pose k observing the features around place(k) (a triangle wave over 12 places, 6
  // features each), added to I.
  PoseAddition Next(int k) {
    const int place = std::abs((k + 6) % 24 - 12);
    std::normal_distribution<double> normal(0.0, 1.0);
    PoseAddition addition;
    Eigen::Matrix<double, 6, 6>& I_pp = addition.I_pp;
    if (k == 0) I_pp = 100.0 * Eigen::Matrix<double, 6, 6>::Identity();  // the anchor
    for (int f = 6 * place; f < 6 * place + 9; ++f) {
      ObservationBlocks obs;
      obs.is_new = offset_of.count(f) == 0;
      if (obs.is_new) {
        offset_of[f] = dim;
        dim += 3;
      }
      obs.feature_offset = offset_of[f];
      Eigen::Matrix<double, 3, 9> h;
      for (int i = 0; i < h.size(); ++i) h(i) = normal(rng);
      I_pp += h.leftCols<6>().transpose() * h.leftCols<6>();
      obs.I_pf = h.leftCols<6>().transpose() * h.rightCols<3>();
      // (+ a little, so that no feature is nearly undetermined: the dense inverse used as
      // the reference stays accurate to 1e-9.)
      obs.I_ff =
          h.rightCols<3>().transpose() * h.rightCols<3>() + 0.5 * Eigen::Matrix3d::Identity();
      addition.observations.push_back(obs);
    }
    addition.pose_offset = dim;
    dim += 6;
    const Eigen::MatrixXd old = I;
    I = Eigen::MatrixXd::Zero(dim, dim);
    I.topLeftCorner(old.rows(), old.cols()) = old;
    I.block<6, 6>(addition.pose_offset, addition.pose_offset) = I_pp;
    for (const ObservationBlocks& obs : addition.observations) {
      I.block<3, 3>(obs.feature_offset, obs.feature_offset) += obs.I_ff;
      I.block<6, 3>(addition.pose_offset, obs.feature_offset) = obs.I_pf;
      I.block<3, 6>(obs.feature_offset, addition.pose_offset) = obs.I_pf.transpose();
    }
    pose_offsets.push_back(addition.pose_offset);
    return addition;
  }

  // The pose Schur complement of I, poses in the order added.
  Eigen::MatrixXd DenseSchur() const {
    std::vector<int> poses, features;
    for (const int offset : pose_offsets) {
      for (int c = 0; c < 6; ++c) poses.push_back(offset + c);
    }
    for (const auto& [feature, offset] : offset_of) {
      for (int c = 0; c < 3; ++c) features.push_back(offset + c);
    }
    const Eigen::MatrixXd I_FF = I(features, features);
    const Eigen::MatrixXd I_PF = I(poses, features);
    return I(poses, poses) - I_PF * Eigen::LLT<Eigen::MatrixXd>(I_FF).solve(I_PF.transpose());
  }

  // A vector of uniform(-1, 1) entries.
  Eigen::VectorXd RandomVector(int size) {
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::VectorXd v(size);
    for (int r = 0; r < size; ++r) v[r] = uniform(rng);
    return v;
  }

  std::mt19937 rng;
  std::map<int, int> offset_of;  // feature -> offset
  std::vector<int> pose_offsets;
  int dim = 0;
  Eigen::MatrixXd I;
};

// A next pose with no information, re-observing one feature: the matrix with it is not
// positive definite.
inline PoseAddition SingularPose(const RandomPoseProblem& problem) {
  PoseAddition singular;
  singular.pose_offset = problem.dim;
  ObservationBlocks obs;
  obs.feature_offset = problem.offset_of.begin()->second;
  singular.observations = {obs};
  return singular;
}

}  // namespace testing
}  // namespace ieslam
