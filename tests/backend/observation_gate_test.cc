#include "backend/observation_gate.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "backend/filter_test_scene.h"

namespace ieslam {
namespace {

// Every feature in the state from its first sighting: the fixture's features are known ones.
InformationFilterOptions GatedOptions() {
  InformationFilterOptions options;
  options.gate_chi2 = 16.27;
  options.min_sightings = 1;
  return options;
}

bool Contains(const std::vector<FeatureObservation>& observations, int64_t feature_id) {
  return std::any_of(
      observations.begin(), observations.end(),
      [feature_id](const FeatureObservation& o) { return o.feature_id == feature_id; });
}

// The observations of `input` whose feature is not in `kept`.
std::vector<FeatureObservation> DroppedFrom(const std::vector<FeatureObservation>& input,
                                            const std::vector<FeatureObservation>& kept) {
  std::vector<FeatureObservation> dropped;
  for (const FeatureObservation& o : input) {
    if (!Contains(kept, o.feature_id)) dropped.push_back(o);
  }
  return dropped;
}

// A filter holding the scene's first two poses (noisy observations), and the third pose's
// observations with the covariance of the known features they see.
struct GateFixture {
  explicit GateFixture(const InformationFilterOptions& options, uint32_t seed = 7)
      : rng(seed), scene(MakeScene(3, 80, &rng)), filter(options, scene.camera) {
    filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, true, &rng));
    filter.AddPose(scene.frame_ids[1], scene.poses[1], Observe(scene, 1, true, &rng));
    truth = Observe(scene, 2, false, &rng);
    observations = Observe(scene, 2, true, &rng);
    std::vector<int64_t> ids;
    for (const FeatureObservation& o : observations) ids.push_back(o.feature_id);
    known = filter.JointFeatureCovariance(ids);
    // A registration's pose: a centimetre and a few tenths of a degree off.
    initial = scene.poses[2];
    initial.head<3>() += Eigen::Vector3d(0.01, -0.006, 0.004);
    initial.tail<3>() += Eigen::Vector3d(0.004, -0.003, 0.002);
  }
  std::vector<size_t> KnownIndices() const {
    std::vector<size_t> indices;
    for (size_t i = 0; i < observations.size(); ++i) {
      if (filter.HasFeature(observations[i].feature_id)) indices.push_back(i);
    }
    return indices;
  }

  std::mt19937 rng;
  Scene scene;
  InformationFilter filter;
  std::vector<FeatureObservation> truth, observations;
  FeatureCovariance known;
  Vector6d initial;
};

TEST(ObservationGateTest, RejectsAPlantedWrongAssociationAndKeepsTheRightOnes) {
  GateFixture f(GatedOptions());
  const std::vector<size_t> known = f.KnownIndices();
  ASSERT_GE(known.size(), 20u);
  // Feature a is given the measurement of feature c, far from it in the image: a wrong
  // association; c keeps its own, right one.
  const size_t a = known[0];
  size_t c = known[1];
  for (const size_t k : known) {
    if ((f.observations[k].z.head<2>() - f.observations[a].z.head<2>()).norm() > 60.0) {
      c = k;
      break;
    }
  }
  ASSERT_GT((f.observations[c].z.head<2>() - f.observations[a].z.head<2>()).norm(), 60.0);
  f.observations[a].z = f.observations[c].z;

  const GatedObservations gated =
      GateObservations(f.filter, f.initial, f.observations, f.known, /*joint=*/true);
  EXPECT_FALSE(Contains(gated.observations, f.observations[a].feature_id));
  EXPECT_TRUE(Contains(gated.observations, f.observations[c].feature_id));
  EXPECT_EQ(gated.stats.tested, static_cast<int>(known.size()));
  EXPECT_EQ(gated.stats.rejected, 1);
  EXPECT_EQ(gated.observations.size(), f.observations.size() - 1);  // new features pass
  EXPECT_EQ(gated.noise_scale, 1.0);
  // The wrong one does not drag the pose: it is fitted as without it.
  std::vector<FeatureObservation> clean = f.observations;
  clean.erase(clean.begin() + a);
  const GatedObservations reference =
      GateObservations(f.filter, f.initial, clean, f.known, /*joint=*/true);
  ASSERT_TRUE(gated.pose_fitted);
  EXPECT_LT((gated.T_w_c - reference.T_w_c).norm(), 1e-6);
  EXPECT_GT((f.initial - reference.T_w_c).norm(), 1e-3);
}

// With delayed initialisation a feature seen by one pose is pending, out of the state; the
// gate tests it through its first sighting as the filter holding every feature would
// (InformationFilter::JointFeatureCovariance): a wrong association on a pending feature is
// rejected, and both filters keep the same observations at the same fitted pose.
TEST(ObservationGateTest, TestsPendingFeaturesAsTheFilterHoldingThemWould) {
  InformationFilterOptions delayed = GatedOptions();
  delayed.min_sightings = 2;
  GateFixture at_once(GatedOptions()), f(delayed);
  std::vector<size_t> pending;
  for (size_t i = 0; i < f.observations.size(); ++i) {
    if (f.filter.IsPending(f.observations[i].feature_id)) pending.push_back(i);
  }
  ASSERT_GE(pending.size(), 2u);
  // Pending feature a is given the measurement of a map feature c far from it in the image.
  const size_t a = pending[0];
  size_t c = a;
  for (const size_t k : at_once.KnownIndices()) {
    if ((f.observations[k].z.head<2>() - f.observations[a].z.head<2>()).norm() > 60.0) {
      c = k;
      break;
    }
  }
  ASSERT_NE(c, a);
  f.observations[a].z = f.observations[c].z;
  at_once.observations[a].z = at_once.observations[c].z;
  std::vector<int64_t> ids;
  for (const FeatureObservation& o : f.observations) ids.push_back(o.feature_id);
  const FeatureCovariance known = f.filter.JointFeatureCovariance(ids);
  ASSERT_EQ(known.feature_ids.size(), at_once.known.feature_ids.size());

  const GatedObservations gated =
      GateObservations(f.filter, f.initial, f.observations, known, /*joint=*/true);
  const GatedObservations reference = GateObservations(
      at_once.filter, at_once.initial, at_once.observations, at_once.known, /*joint=*/true);
  EXPECT_FALSE(Contains(gated.observations, f.observations[a].feature_id));
  EXPECT_TRUE(Contains(gated.observations, f.observations[pending[1]].feature_id));
  EXPECT_EQ(gated.stats.tested, reference.stats.tested);
  EXPECT_EQ(gated.stats.rejected, reference.stats.rejected);
  ASSERT_EQ(gated.observations.size(), reference.observations.size());
  for (size_t i = 0; i < gated.observations.size(); ++i) {
    EXPECT_EQ(gated.observations[i].feature_id, reference.observations[i].feature_id);
  }
  EXPECT_DOUBLE_EQ(gated.noise_scale, reference.noise_scale);
  ASSERT_TRUE(gated.pose_fitted && reference.pose_fitted);
  EXPECT_LT((gated.T_w_c - reference.T_w_c).norm(), 1e-5);
}

TEST(ObservationGateTest, OffKeepsEveryObservation) {
  InformationFilterOptions options;
  options.gate_chi2 = 0.0;
  GateFixture f(options);
  f.observations[f.KnownIndices()[0]].z.head<2>() += Eigen::Vector2d(80.0, -50.0);
  const GatedObservations gated =
      GateObservations(f.filter, f.initial, f.observations, f.known, /*joint=*/true);
  EXPECT_EQ(gated.observations.size(), f.observations.size());
  EXPECT_EQ(gated.stats.rejected, 0);
  EXPECT_FALSE(gated.pose_fitted);
}

// Noise three times what Q states: the joint test fails, the frame's Q is scaled by its
// variance factor (about 9) and the single gates then keep nearly all; without the
// adaptation they shed the tails of the wider distribution.
TEST(ObservationGateTest, ScalesQOfAFrameNoisierThanStated) {
  InformationFilterOptions options = GatedOptions();
  GateFixture f(options);
  for (size_t i = 0; i < f.observations.size(); ++i) {
    f.observations[i].z = f.truth[i].z + 3.0 * (f.observations[i].z - f.truth[i].z);
  }
  const GatedObservations adapted =
      GateObservations(f.filter, f.initial, f.observations, f.known, /*joint=*/true);
  EXPECT_GT(adapted.noise_scale, 4.0);
  EXPECT_LT(adapted.noise_scale, 16.0);
  EXPECT_LE(adapted.stats.rejected_share(), 0.05);
  for (const FeatureObservation& kept : adapted.observations) {
    const auto input = std::find_if(
        f.observations.begin(), f.observations.end(),
        [&kept](const FeatureObservation& o) { return o.feature_id == kept.feature_id; });
    ASSERT_NE(input, f.observations.end());
    EXPECT_NEAR(kept.Q(0, 0), adapted.noise_scale * input->Q(0, 0), 1e-12);
  }

  options.adapt_noise = false;
  GateFixture g(options);
  g.observations = f.observations;
  const GatedObservations fixed =
      GateObservations(g.filter, g.initial, g.observations, g.known, /*joint=*/true);
  EXPECT_EQ(fixed.noise_scale, 1.0);
  EXPECT_GT(fixed.stats.rejected_share(), adapted.stats.rejected_share());
}

// Several wrong associations at once: the robust fit keeps them from dragging the pose the
// first gate tests against, so each is rejected and every right one kept.
TEST(ObservationGateTest, RejectsSeveralWrongAssociationsAtOnce) {
  GateFixture f(GatedOptions());
  const std::vector<size_t> known = f.KnownIndices();
  ASSERT_GE(known.size(), 30u);
  std::vector<FeatureObservation> clean = f.observations;
  std::vector<int64_t> wrong;
  // Features 0, 2, 4, 6 of the known ones take the measurement of one on the far side.
  for (size_t w = 0; w < 8; w += 2) {
    const size_t a = known[w];
    const size_t c = known[known.size() - 1 - w];
    ASSERT_GT((f.observations[c].z.head<2>() - f.observations[a].z.head<2>()).norm(), 30.0);
    f.observations[a].z = f.observations[c].z;
    wrong.push_back(f.observations[a].feature_id);
  }
  const GatedObservations gated =
      GateObservations(f.filter, f.initial, f.observations, f.known, /*joint=*/true);
  for (const int64_t id : wrong) EXPECT_FALSE(Contains(gated.observations, id)) << id;
  EXPECT_EQ(gated.stats.rejected, 4);
  EXPECT_EQ(gated.noise_scale, 1.0);
  std::vector<FeatureObservation> right;
  for (const FeatureObservation& o : clean) {
    if (std::find(wrong.begin(), wrong.end(), o.feature_id) == wrong.end()) right.push_back(o);
  }
  const GatedObservations reference =
      GateObservations(f.filter, f.initial, right, f.known, /*joint=*/true);
  ASSERT_TRUE(gated.pose_fitted);
  EXPECT_EQ(reference.stats.rejected, 0);
  EXPECT_LT((gated.T_w_c - reference.T_w_c).norm(), 1e-6);
}

// Two known features leave the rotation about the line through them free: no pose is fitted
// (the initial one stays), and the two are tested against it.
TEST(ObservationGateTest, TwoKnownFeaturesFitNoPose) {
  GateFixture f(GatedOptions());
  const std::vector<size_t> known = f.KnownIndices();
  std::vector<FeatureObservation> two;
  for (size_t i = 0; i < f.observations.size(); ++i) {
    const bool is_known = f.filter.HasFeature(f.observations[i].feature_id);
    if (!is_known || i == known[0] || i == known[1]) two.push_back(f.truth[i]);
  }
  const GatedObservations gated =
      GateObservations(f.filter, f.scene.poses[2], two, f.known, /*joint=*/true);
  EXPECT_FALSE(gated.pose_fitted);
  EXPECT_EQ(gated.T_w_c, f.scene.poses[2]);
  EXPECT_EQ(gated.stats.tested, 2);
  EXPECT_EQ(gated.stats.rejected, 0);
  EXPECT_EQ(gated.observations.size(), two.size());
}

// An error of squared Mahalanobis length d2 against the observation's innovation covariance
// Q + J_f P_f J_f^T, in a direction that alternates with `sign`.
Eigen::Vector3d ErrorOfLength(const GateFixture& f, size_t i, double d2, double sign) {
  const FeatureObservation& o = f.observations[i];
  Matrix36d J_x;
  Eigen::Matrix3d J_f;
  PredictObservation(f.scene.poses[2], f.filter.feature(o.feature_id), f.scene.camera, &J_x, &J_f);
  const int block = f.known.index.at(o.feature_id);
  const Eigen::Matrix3d S =
      o.Q + J_f * f.known.covariance.block<3, 3>(3 * block, 3 * block) * J_f.transpose();
  const Eigen::Matrix3d L = S.llt().matrixL();
  return sign * std::sqrt(d2) * L * Eigen::Vector3d(1.0, -1.0, 0.0).normalized();
}

// Errors each inside the single gate (d2 = 13 of 16.27), on a third of the features: together
// they fail the joint test, and with the Q scaling off the worst are dropped, and the pose
// refitted, until the set passes; only planted ones go.
TEST(ObservationGateTest, JointTestDropsTheWorstUntilTheSetPasses) {
  InformationFilterOptions options = GatedOptions();
  options.adapt_noise = false;
  GateFixture f(options);
  const std::vector<size_t> known = f.KnownIndices();
  ASSERT_GE(known.size(), 45u);
  std::vector<int64_t> planted;
  for (size_t w = 0; w < 15; ++w) {
    const size_t i = known[3 * w];
    f.observations[i].z = f.truth[i].z + ErrorOfLength(f, i, 13.0, w % 2 == 0 ? 1.0 : -1.0);
    planted.push_back(f.observations[i].feature_id);
  }
  const GatedObservations gated =
      GateObservations(f.filter, f.initial, f.observations, f.known, /*joint=*/true);
  EXPECT_GT(gated.stats.rejected_joint, 0);
  EXPECT_EQ(gated.stats.incompatible_frames, 0);
  for (const FeatureObservation& o : DroppedFrom(f.observations, gated.observations)) {
    EXPECT_NE(std::find(planted.begin(), planted.end(), o.feature_id), planted.end())
        << "feature " << o.feature_id << " was not planted";
  }
}

}  // namespace
}  // namespace ieslam
