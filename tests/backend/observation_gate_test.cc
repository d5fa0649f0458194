#include "backend/observation_gate.h"

#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "backend/filter_test_scene.h"

namespace ieslam {
namespace {

InformationFilterOptions GatedOptions() {
  InformationFilterOptions options;
  options.gate_chi2 = 16.27;
  return options;
}

bool Contains(const std::vector<FeatureObservation>& observations, int64_t feature_id) {
  return std::any_of(
      observations.begin(), observations.end(),
      [feature_id](const FeatureObservation& o) { return o.feature_id == feature_id; });
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
  EXPECT_NEAR(adapted.observations[0].Q(0, 0), adapted.noise_scale * f.observations[0].Q(0, 0),
              1e-12);

  options.adapt_noise = false;
  GateFixture g(options);
  g.observations = f.observations;
  const GatedObservations fixed =
      GateObservations(g.filter, g.initial, g.observations, g.known, /*joint=*/true);
  EXPECT_EQ(fixed.noise_scale, 1.0);
  EXPECT_GT(fixed.stats.rejected_share(), adapted.stats.rejected_share());
}

}  // namespace
}  // namespace ieslam
