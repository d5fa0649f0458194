// A filter taken over from its snapshot goes on as the filter it was taken of: the same state,
// covariances and log det, the same next update; so does one whose factor was released; and a
// snapshot that does not hold together is refused, leaving the filter empty.
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "backend/filter_test_scene.h"
#include "backend/information_filter.h"
#include "core/error.h"

namespace ieslam {
namespace {

// `s` with the entries of columns [c0, c1) that lie in rows [r0, r1) removed, or with one entry
// (r0, c0) of `value` added when `value` is not zero.
FilterSnapshot Edited(FilterSnapshot s, int c0, int c1, int r0, int r1, double value = 0.0) {
  std::vector<int> starts = {0}, rows;
  std::vector<double> values;
  for (int c = 0; c < s.dim; ++c) {
    bool added = value == 0.0 || c != c0;
    for (int k = s.column_starts[c]; k < s.column_starts[c + 1]; ++k) {
      if (!added && s.rows[k] > r0) {
        rows.push_back(r0);
        values.push_back(value);
        added = true;
      }
      if (value == 0.0 && c >= c0 && c < c1 && s.rows[k] >= r0 && s.rows[k] < r1) continue;
      rows.push_back(s.rows[k]);
      values.push_back(s.values[k]);
    }
    starts.push_back(static_cast<int>(rows.size()));
  }
  s.column_starts = starts;
  s.rows = rows;
  s.values = values;
  return s;
}

// Filters of the first `poses` poses of a scene, on the dense pose Schur complement, the sparse
// factor, and one that hands over from the first to the second within the poses restored.
class InformationFilterSnapshotTest : public ::testing::TestWithParam<int> {
 protected:
  InformationFilterOptions Options(int min_sightings = 1) const {
    InformationFilterOptions options;
    options.max_dense_pose_dim = GetParam();
    options.min_sightings = min_sightings;
    return options;
  }
  void Fill(const Scene& scene, int poses, std::mt19937* rng, InformationFilter* filter) const {
    filter->AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, true, rng));
    for (int i = 1; i < poses; ++i) {
      filter->AddPose(scene.frame_ids[i], Perturb(scene.poses[i], 0.02, 0.01, rng),
                      Observe(scene, i, true, rng));
    }
  }
  // Poses [begin, end) of the scene into both filters, with the same observations and initial
  // values.
  static void AddToBoth(const Scene& scene, int begin, int end, std::mt19937* rng,
                        InformationFilter* a, InformationFilter* b) {
    for (int i = begin; i < end; ++i) {
      const std::vector<FeatureObservation> observations = Observe(scene, i, true, rng);
      const Vector6d initial = Perturb(scene.poses[i], 0.02, 0.01, rng);
      a->AddPose(scene.frame_ids[i], initial, observations);
      b->AddPose(scene.frame_ids[i], initial, observations);
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
  AddToBoth(scene, 7, 9, &rng, &original, &restored);
  EXPECT_EQ(restored.uses_pose_schur(), original.uses_pose_schur());
  EXPECT_LT((restored.state() - original.state()).lpNorm<Eigen::Infinity>(), 1e-9);
}

// A released factor is built anew from the matrix by the first query or update that needs
// it: the same answers as the filter that kept its factor, and the same next updates.
TEST_P(InformationFilterSnapshotTest, AReleasedFactorIsBuiltAnewWhenNeeded) {
  for (const int min_sightings : {1, 2}) {
    SCOPED_TRACE("min_sightings " + std::to_string(min_sightings));
    std::mt19937 rng(11);
    const Scene scene = MakeScene(9, 80, &rng);
    // Two filters of the same updates.
    InformationFilter kept(Options(min_sightings), scene.camera);
    InformationFilter released(Options(min_sightings), scene.camera);
    std::mt19937 rng_kept(12), rng_released(12);
    Fill(scene, 7, &rng_kept, &kept);
    Fill(scene, 7, &rng_released, &released);
    released.ReleaseFactor();
    // Nothing but the factor is released; the first query builds it.
    EXPECT_TRUE(released.state() == kept.state());
    EXPECT_EQ(released.num_pending_features(), kept.num_pending_features());
    const double log_det = kept.LogDetInformation();
    EXPECT_NEAR(released.LogDetInformation(), log_det, 1e-10 * std::abs(log_det));
    EXPECT_EQ(released.uses_pose_schur(), kept.uses_pose_schur());
    // The factor is the one Restore builds (the sparse factor's ordering is chosen anew, so
    // its fill may differ from the kept factor's).
    InformationFilter restored(Options(min_sightings), scene.camera);
    restored.Restore(kept.Snapshot());
    EXPECT_EQ(released.FactorNonzeros(), restored.FactorNonzeros());
    const int last = kept.frame_ids().back();
    EXPECT_LT((released.PoseCovariance(last) - kept.PoseCovariance(last)).norm(),
              1e-9 * kept.PoseCovariance(last).norm());

    // Released again, then updated first: the update builds the factor before it changes the
    // matrix, and the state follows the kept filter's.
    released.ReleaseFactor();
    AddToBoth(scene, 7, 9, &rng, &kept, &released);
    EXPECT_EQ(released.state_dim(), kept.state_dim());
    EXPECT_LT((released.state() - kept.state()).lpNorm<Eigen::Infinity>(), 1e-9);
    EXPECT_LT(
        (released.PoseCovariance(scene.frame_ids[8]) - kept.PoseCovariance(scene.frame_ids[8]))
            .norm(),
        1e-9 * kept.PoseCovariance(scene.frame_ids[8]).norm());
  }
  // An empty filter's released factor is an empty one again: the first pose goes in.
  std::mt19937 rng(13);
  const Scene scene = MakeScene(3, 40, &rng);
  InformationFilter empty(Options(), scene.camera);
  empty.ReleaseFactor();
  Fill(scene, 3, &rng, &empty);
  EXPECT_EQ(empty.num_poses(), 3);
}

// With delayed initialisation the snapshot holds the pending features' sightings too, and
// the features that entered at a later sighting couple with earlier poses in their columns:
// the restored filter brings the same pending features in as the original does.
TEST_P(InformationFilterSnapshotTest, ARestoredDelayedFilterGoesOnWithItsPendingFeatures) {
  std::mt19937 rng(7);
  const Scene scene = MakeScene(9, 80, &rng);
  InformationFilter original(Options(2), scene.camera);
  Fill(scene, 7, &rng, &original);
  const FilterSnapshot snapshot = original.Snapshot();
  ASSERT_GT(snapshot.pending.size(), 0u);
  InformationFilter restored(Options(2), scene.camera);
  restored.Restore(snapshot);
  EXPECT_EQ(restored.num_pending_features(), original.num_pending_features());
  for (const PendingFeature& p : original.PendingFeatures()) EXPECT_TRUE(restored.IsPending(p.id));
  EXPECT_TRUE(restored.state() == original.state());
  const double log_det = original.LogDetInformation();
  EXPECT_NEAR(restored.LogDetInformation(), log_det, 1e-10 * std::abs(log_det));
  int entered = 0;
  for (int i = 7; i < 9; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, true, &rng);
    const Vector6d initial = Perturb(scene.poses[i], 0.02, 0.01, &rng);
    entered += original.CountEnteringFeatures(observations);
    original.AddPose(scene.frame_ids[i], initial, observations);
    restored.AddPose(scene.frame_ids[i], initial, observations);
  }
  EXPECT_GT(entered, 0);
  EXPECT_EQ(restored.feature_ids(), original.feature_ids());
  EXPECT_EQ(restored.num_pending_features(), original.num_pending_features());
  EXPECT_LT((restored.state() - original.state()).lpNorm<Eigen::Infinity>(), 1e-9);

  // A pending feature seen from no pose of the filter, or one in the state, is refused.
  InformationFilter filter(Options(2), scene.camera);
  FilterSnapshot bad = snapshot;
  bad.pending.front().sightings.front().frame_id = -7;
  EXPECT_THROW(filter.Restore(bad), DataError);
  bad = snapshot;
  bad.pending.front().id = snapshot.feature_offsets.front().first;
  EXPECT_THROW(filter.Restore(bad), DataError);
  filter.Restore(snapshot);
  EXPECT_EQ(filter.num_pending_features(), static_cast<int>(snapshot.pending.size()));
}

TEST_P(InformationFilterSnapshotTest, ASnapshotThatDoesNotHoldTogetherIsRefused) {
  std::mt19937 rng(6);
  const Scene scene = MakeScene(4, 60, &rng);
  InformationFilter original(Options(), scene.camera);
  Fill(scene, 4, &rng, &original);
  const FilterSnapshot good = original.Snapshot();
  InformationFilter filter(Options(), scene.camera);
  const auto refused = [&](const FilterSnapshot& bad, const std::string& says) {
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
  refused(bad, "not in the order of their offsets");
  bad = good;
  bad.feature_offsets[2].first = bad.feature_offsets[1].first;
  refused(bad, "is there twice");
  bad = good;
  int coupled = 0;  // the first column with an entry above its diagonal
  while (good.column_starts[coupled + 1] - good.column_starts[coupled] < 2) ++coupled;
  bad.rows[good.column_starts[coupled]] = -1;
  refused(bad, "negative row");
  bad = good;
  bad.values[bad.column_starts[1] - 1] = -1.0;  // the first feature's first diagonal entry
  refused(bad, "not positive definite");

  // Refusals found while the factor is being built: a pose coupled with an earlier pose, and a
  // feature its first pose does not see.
  const int pose0 = good.pose_offsets[0].second, pose1 = good.pose_offsets[1].second;
  refused(Edited(good, pose1, pose1 + 6, pose0, pose0, 0.5), "couples with row");
  const int feature = good.feature_offsets[0].second;
  refused(Edited(good, pose0, pose0 + 6, feature, feature + 3), "is not observed by the pose");

  // Nothing of a refusal stays behind: the same filter then takes the good snapshot.
  filter.Restore(good);
  EXPECT_TRUE(filter.state() == original.state());
  const int last = original.frame_ids().back();
  EXPECT_LT((filter.PoseCovariance(last) - original.PoseCovariance(last)).norm(),
            1e-9 * original.PoseCovariance(last).norm());
}

}  // namespace
}  // namespace ieslam
