// A filter taken over from its snapshot goes on as the filter it was taken of: the same state,
// covariances and log det, the same next update; and a snapshot that does not hold together is
// refused, leaving the filter empty.
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "backend/filter_test_scene.h"
#include "backend/information_filter.h"
#include "core/error.h"

namespace ieslam {
namespace {

Vector6d Perturb(const Vector6d& pose, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Vector6d perturbed = pose;
  for (int k = 0; k < 3; ++k) perturbed[k] += 0.02 * normal(*rng);
  for (int k = 3; k < 6; ++k) perturbed[k] += 0.01 * normal(*rng);
  return perturbed;
}

// Filters of the first `poses` poses of a scene, on the dense pose Schur complement, the sparse
// factor, and one that hands over from the first to the second within the poses restored.
class InformationFilterSnapshotTest : public ::testing::TestWithParam<int> {
 protected:
  InformationFilterOptions Options() const {
    InformationFilterOptions options;
    options.max_dense_pose_dim = GetParam();
    return options;
  }
  void Fill(const Scene& scene, int poses, std::mt19937* rng, InformationFilter* filter) const {
    filter->AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, true, rng));
    for (int i = 1; i < poses; ++i) {
      filter->AddPose(scene.frame_ids[i], Perturb(scene.poses[i], rng),
                      Observe(scene, i, true, rng));
    }
  }
};

INSTANTIATE_TEST_SUITE_P(Factorisations, InformationFilterSnapshotTest,
                         ::testing::Values(0, 24, 2400),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return info.param == 0    ? std::string("Sparse")
                                  : info.param == 24 ? std::string("HandOver")
                                                     : std::string("PoseSchur");
                         });

TEST_P(InformationFilterSnapshotTest, ARestoredFilterGoesOnAsTheOriginal) {
  std::mt19937 rng(5);
  const Scene scene = MakeScene(9, 80, &rng);
  InformationFilter original(Options(), scene.camera);
  Fill(scene, 7, &rng, &original);
  const FilterSnapshot snapshot = original.Snapshot();
  InformationFilter restored(Options(), scene.camera);
  restored.Restore(snapshot);

  EXPECT_EQ(restored.frame_ids(), original.frame_ids());
  EXPECT_EQ(restored.feature_ids(), original.feature_ids());
  EXPECT_TRUE(restored.state() == original.state());
  EXPECT_TRUE(restored.information_vector() == original.information_vector());
  EXPECT_EQ(restored.uses_pose_schur(), original.uses_pose_schur());
  const double log_det = original.LogDetInformation();
  EXPECT_NEAR(restored.LogDetInformation(), log_det, 1e-10 * std::abs(log_det));
  for (int frame : original.frame_ids()) {
    const Matrix6d a = original.PoseCovariance(frame), b = restored.PoseCovariance(frame);
    EXPECT_LT((a - b).norm(), 1e-9 * a.norm() + 1e-15) << "frame " << frame;
  }
  const std::vector<VariableRef> some = {VariableRef::Feature(original.feature_ids().front()),
                                         VariableRef::Feature(original.feature_ids().back()),
                                         VariableRef::Pose(original.frame_ids().back())};
  const Eigen::MatrixXd a = original.MarginalCovariance(some),
                        b = restored.MarginalCovariance(some);
  EXPECT_LT((a - b).norm(), 1e-9 * a.norm());

  // The next poses, identically: the same estimate.
  for (int i = 7; i < 9; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, true, &rng);
    const Vector6d initial = Perturb(scene.poses[i], &rng);
    original.AddPose(scene.frame_ids[i], initial, observations);
    restored.AddPose(scene.frame_ids[i], initial, observations);
  }
  EXPECT_EQ(restored.uses_pose_schur(), original.uses_pose_schur());
  EXPECT_LT((restored.state() - original.state()).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST_P(InformationFilterSnapshotTest, ASnapshotThatDoesNotHoldTogetherIsRefused) {
  std::mt19937 rng(6);
  const Scene scene = MakeScene(4, 60, &rng);
  InformationFilter original(Options(), scene.camera);
  Fill(scene, 4, &rng, &original);
  const FilterSnapshot good = original.Snapshot();
  const auto refused = [&](FilterSnapshot bad, const std::string& says) {
    InformationFilter filter(Options(), scene.camera);
    try {
      filter.Restore(bad);
      ADD_FAILURE() << "not refused: " << says;
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
    EXPECT_EQ(filter.state_dim(), 0);
    EXPECT_EQ(filter.num_poses(), 0);
  };
  FilterSnapshot bad = good;
  bad.state.conservativeResize(bad.dim - 1);
  refused(bad, "state entries");
  bad = good;
  bad.feature_offsets[1].second = bad.feature_offsets[0].second;
  refused(bad, "two variables at offset");
  bad = good;
  std::swap(bad.pose_offsets[0].second, bad.pose_offsets[1].second);
  refused(bad, "");
  bad = good;
  bad.feature_offsets[2].first = bad.feature_offsets[1].first;
  refused(bad, "is there twice");
  bad = good;
  bad.values[bad.column_starts[1] - 1] = -1.0;  // the first feature's first diagonal entry
  refused(bad, "not positive definite");
}

}  // namespace
}  // namespace ieslam
