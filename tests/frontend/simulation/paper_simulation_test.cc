#include "frontend/simulation/paper_simulation.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numeric>

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

int Median(std::vector<int> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

int NumObservations(const SimulatedDataset& d) {
  int total = 0;
  for (const auto& obs : d.observations) total += static_cast<int>(obs.size());
  return total;
}

SimulationOptions NoiseFree() {
  SimulationOptions o;
  o.add_noise = false;
  return o;
}

TEST(PaperSimulation, DefaultsAreThePapersSetUp) {
  const SimulationOptions o;
  std::string why;
  ASSERT_TRUE(o.Check(&why)) << why;
  EXPECT_EQ(o.trajectory.num_poses, 300);
  EXPECT_EQ(o.trajectory.num_loops, 2);
  EXPECT_EQ(o.feature_count, 2000);
  EXPECT_DOUBLE_EQ(o.volume_size_m.prod(), 2400.0);
  EXPECT_DOUBLE_EQ(o.volume_size_m.z(), 6.0);  // the 6 m is the height
  EXPECT_DOUBLE_EQ(o.max_range_m, 7.5);
  EXPECT_EQ(o.camera.width, 1024);
  EXPECT_EQ(o.camera.height, 768);
  const double hfov = 2.0 * std::atan(0.5 * o.camera.width / o.camera.fx) / kDeg;
  EXPECT_GT(hfov, 55.0);
  EXPECT_LT(hfov, 75.0);
  EXPECT_TRUE(PaperSimulationRig(o).Check(&why)) << why;

  const SimulatedDataset d = SimulatePaperScenario(o);
  ASSERT_EQ(d.num_poses(), 300);
  EXPECT_EQ(d.features_true.size(), 2000u);
  ASSERT_EQ(d.observations.size(), 300u);
  ASSERT_EQ(d.truth.size(), 300u);
  // Every pose lies inside the feature volume.
  for (const Vector6d& T : d.T_w_c_true) {
    EXPECT_TRUE(
        ((T.head<3>() - o.volume_centre_m).cwiseAbs().array() < 0.5 * o.volume_size_m.array())
            .all())
        << T.transpose();
  }
}

TEST(PaperSimulation, NoiseFreeObservationsAreExactPredictionsOfEveryFeatureInView) {
  const SimulationOptions o = NoiseFree();
  const SimulatedDataset d = SimulatePaperScenario(o);
  for (int k = 0; k < d.num_poses(); ++k) {
    ASSERT_EQ(d.observations[k].size(), d.truth[k].size());
    // Independent count of the features in view.
    int in_view = 0;
    for (const Eigen::Vector3d& p_w : d.features_true) {
      const Eigen::Vector3d p_c = WorldToCamera(d.T_w_c_true[k], p_w);
      if (p_c.z() <= 0.0 || p_c.norm() < o.min_range_m || p_c.norm() > o.max_range_m) continue;
      const Eigen::Vector2d uv = o.camera.K().topLeftCorner<2, 3>() * (p_c / p_c.z());
      if (uv.x() >= -0.5 && uv.y() >= -0.5 && uv.x() < 1023.5 && uv.y() < 767.5) ++in_view;
    }
    EXPECT_EQ(static_cast<int>(d.observations[k].size()), in_view) << "pose " << k;
    int64_t previous_id = -1;
    for (size_t j = 0; j < d.observations[k].size(); ++j) {
      const FeatureObservation& obs = d.observations[k][j];
      ASSERT_GT(obs.feature_id, previous_id);  // increasing ids, no duplicates
      previous_id = obs.feature_id;
      const Eigen::Vector3d z =
          PredictObservation(d.T_w_c_true[k], d.features_true[obs.feature_id], d.camera);
      EXPECT_EQ(obs.z, z);
      EXPECT_EQ(d.truth[k][j].z_true, z);
      EXPECT_FALSE(d.truth[k][j].outlier);
      EXPECT_EQ(obs.Q, ObservationCovariance(1.0, o.range_noise, z.z()));
      EXPECT_GT(obs.Q(2, 2), 0.0);
    }
  }
}

TEST(PaperSimulation, EveryPoseSeesEnoughFeatures) {
  for (auto kind : {SimulatedTrajectoryKind::kPolygon, SimulatedTrajectoryKind::kRectangle}) {
    SimulationOptions o;
    o.trajectory.kind = kind;
    const std::vector<int> counts = VisibleFeatureCounts(SimulatePaperScenario(o));
    const int min_count = *std::min_element(counts.begin(), counts.end());
    std::cout << ToString(kind) << ": visible features per pose min " << min_count << " median "
              << Median(counts) << " max " << *std::max_element(counts.begin(), counts.end())
              << "\n";
    EXPECT_GE(min_count, 15) << ToString(kind);
  }
}

TEST(PaperSimulation, SeedsSeparateSceneFromNoise) {
  const SimulationOptions o;
  const SimulatedDataset a = SimulatePaperScenario(o);
  const SimulatedDataset b = SimulatePaperScenario(o);
  ASSERT_EQ(a.features_true, b.features_true);
  ASSERT_EQ(a.T_w_c_true, b.T_w_c_true);
  for (int k = 0; k < a.num_poses(); ++k) {
    ASSERT_EQ(a.observations[k].size(), b.observations[k].size());
    for (size_t j = 0; j < a.observations[k].size(); ++j) {
      EXPECT_EQ(a.observations[k][j].z, b.observations[k][j].z);  // bit for bit
      EXPECT_EQ(a.observations[k][j].Q, b.observations[k][j].Q);
    }
  }

  SimulationOptions other_noise = o;
  other_noise.noise_seed = o.noise_seed + 1;
  const SimulatedDataset c = SimulatePaperScenario(other_noise);
  EXPECT_EQ(c.features_true, a.features_true);
  EXPECT_EQ(c.T_w_c_true, a.T_w_c_true);
  int differing = 0;
  for (int k = 0; k < a.num_poses(); ++k) {
    ASSERT_EQ(c.observations[k].size(), a.observations[k].size());
    for (size_t j = 0; j < a.observations[k].size(); ++j) {
      EXPECT_EQ(c.truth[k][j].z_true, a.truth[k][j].z_true);
      differing += c.observations[k][j].z != a.observations[k][j].z;
    }
  }
  EXPECT_EQ(differing, NumObservations(a));

  SimulationOptions other_scene = o;
  other_scene.scene_seed = o.scene_seed + 1;
  const SimulatedDataset e = SimulatePaperScenario(other_scene);
  EXPECT_NE(e.features_true, a.features_true);
  EXPECT_EQ(e.T_w_c_true, a.T_w_c_true);  // the path is not random
}

TEST(PaperSimulation, NoiseMatchesItsCovariance) {
  const SimulatedDataset d = SimulatePaperScenario(SimulationOptions());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum_sq = Eigen::Vector3d::Zero();
  const int n = NumObservations(d);
  ASSERT_GT(n, 10000);
  for (int k = 0; k < d.num_poses(); ++k) {
    for (size_t j = 0; j < d.observations[k].size(); ++j) {
      const FeatureObservation& obs = d.observations[k][j];
      const Eigen::Vector3d e =
          (obs.z - d.truth[k][j].z_true).cwiseQuotient(obs.Q.diagonal().cwiseSqrt());
      sum += e;
      sum_sq += e.cwiseAbs2();
    }
  }
  const Eigen::Vector3d mean = sum / n;
  const Eigen::Vector3d variance = sum_sq / n - mean.cwiseAbs2();
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(mean(i), 0.0, 5.0 / std::sqrt(n)) << i;
    EXPECT_NEAR(variance(i), 1.0, 0.05) << i;
  }
}

TEST(PaperSimulation, OutlierFractionIsRespectedAndFlagged) {
  SimulationOptions o;
  o.outlier_fraction = 0.1;
  const SimulatedDataset d = SimulatePaperScenario(o);
  const SimulatedDataset clean = SimulatePaperScenario(SimulationOptions());
  int outliers = 0;
  for (int k = 0; k < d.num_poses(); ++k) {
    ASSERT_EQ(d.observations[k].size(), clean.observations[k].size());
    for (size_t j = 0; j < d.observations[k].size(); ++j) {
      const FeatureObservation& obs = d.observations[k][j];
      if (d.truth[k][j].outlier) {
        ++outliers;
        EXPECT_TRUE(d.camera.InImage(obs.z.head<2>()));
        EXPECT_GE(obs.z.z(), o.min_range_m);
        EXPECT_LE(obs.z.z(), o.max_range_m);
      } else {
        // Switching outliers on leaves the inliers' noise untouched.
        EXPECT_EQ(obs.z, clean.observations[k][j].z);
      }
    }
  }
  const double fraction = static_cast<double>(outliers) / NumObservations(d);
  EXPECT_NEAR(fraction, 0.1, 0.01);
}

TEST(PaperSimulation, FeaturePoorStretchSeesFewerFeatures) {
  SimulationOptions o;
  o.feature_poor_start = 0.25;
  o.feature_poor_length = 0.1;
  const SimulatedDataset d = SimulatePaperScenario(o);
  EXPECT_LT(d.features_true.size(), 2000u);
  const std::vector<int> counts = VisibleFeatureCounts(d);
  std::vector<int> poor, rest;
  for (int k = 0; k < d.num_poses(); ++k) {
    (d.in_feature_poor_stretch[k] ? poor : rest).push_back(counts[k]);
  }
  // A tenth of each loop: poses 37.5 .. 52.5 of the first 150 and their twins in the second.
  ASSERT_EQ(poor.size(), 30u);
  EXPECT_TRUE(d.in_feature_poor_stretch[38]);
  EXPECT_TRUE(d.in_feature_poor_stretch[188]);
  EXPECT_FALSE(d.in_feature_poor_stretch[37]);
  EXPECT_FALSE(d.in_feature_poor_stretch[53]);
  std::cout << "feature-poor stretch: visible min " << *std::min_element(poor.begin(), poor.end())
            << " median " << Median(poor) << " vs median " << Median(rest) << " elsewhere\n";
  EXPECT_LT(Median(poor), 0.35 * Median(rest));
  EXPECT_GT(*std::min_element(poor.begin(), poor.end()), 0);
  // Ids stay 0..M-1 and every observation points at an existing feature.
  for (const auto& pose_observations : d.observations) {
    for (const FeatureObservation& obs : pose_observations) {
      EXPECT_LT(obs.feature_id, static_cast<int64_t>(d.features_true.size()));
    }
  }
}

TEST(PaperSimulation, CheckRejectsBadOptions) {
  std::vector<SimulationOptions> bad(12);
  bad[0].feature_count = 0;
  bad[1].max_range_m = bad[1].min_range_m;
  bad[2].outlier_fraction = 1.5;
  bad[3].pixel_sigma = 0.0;
  bad[4].trajectory.num_poses = 1;
  bad[5].trajectory.pitch_wobble_deg = 80.0;
  bad[6].camera.distortion[0] = 0.1;
  bad[7].feature_poor_start = 0.9;
  bad[7].feature_poor_length = 0.2;
  bad[8].range_noise = RangeNoiseModel{};
  bad[9].volume_size_m.y() = -1.0;
  bad[10].trajectory.polygon_sides = 2;
  bad[11].camera.fx = 0.0;
  for (size_t i = 0; i < bad.size(); ++i) {
    std::string why;
    EXPECT_FALSE(bad[i].Check(&why)) << "case " << i;
    EXPECT_FALSE(why.empty()) << "case " << i;
    EXPECT_THROW(SimulatePaperScenario(bad[i]), ConfigError) << "case " << i;
  }
}

}  // namespace
}  // namespace ieslam
