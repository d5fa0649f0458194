#include "frontend/simulation/known_association_source.h"

#include <gtest/gtest.h>

#include "frontend/simulation/paper_simulation.h"

namespace ieslam {
namespace {

SimulatedDataset NoiseFreeSimulation() {
  SimulationOptions options;
  options.trajectory.num_poses = 40;
  options.trajectory.num_loops = 1;
  options.add_noise = false;
  return SimulatePaperScenario(options);
}

KnownAssociationSource SourceOf(const SimulatedDataset& data) {
  std::vector<double> timestamps;
  for (int k = 0; k < data.num_poses(); ++k) timestamps.push_back(0.5 * k);
  return KnownAssociationSource(data.observations, timestamps, data.camera,
                                PoseToIsometry(data.T_w_c_true[0]));
}

// Without noise the closed-form fit gives the true relative pose.
TEST(KnownAssociationSourceTest, RegistersToTheBaseFrameItSharesMostWith) {
  const SimulatedDataset data = NoiseFreeSimulation();
  KnownAssociationSource source = SourceOf(data);
  EXPECT_EQ(source.size(), 40);
  EXPECT_EQ(source.timestamp(3), 1.5);
  const CandidateFrame first = source.PrepareFirst(0);
  EXPECT_TRUE(first.registered);
  EXPECT_TRUE(first.T_base_c.isApprox(PoseToIsometry(data.T_w_c_true[0])));
  source.Commit(first);
  const CandidateFrame next = source.Prepare(2);
  ASSERT_TRUE(next.registered) << next.reason;
  EXPECT_EQ(next.base_frame, 0);
  EXPECT_GT(next.common_features, 10);
  const Eigen::Isometry3d T_0_2 =
      PoseToIsometry(data.T_w_c_true[0]).inverse() * PoseToIsometry(data.T_w_c_true[2]);
  EXPECT_LT((next.T_base_c.matrix() - T_0_2.matrix()).norm(), 1e-9);
  EXPECT_EQ(next.observations.size(), data.observations[2].size());
}

TEST(KnownAssociationSourceTest, AFrameSharingNothingIsNotRegistered) {
  const SimulatedDataset data = NoiseFreeSimulation();
  KnownAssociationSource source = SourceOf(data);
  // Nothing committed yet: no base frame shares a feature.
  const CandidateFrame lonely = source.Prepare(5);
  EXPECT_FALSE(lonely.registered);
  EXPECT_NE(lonely.reason.find("shares no feature"), std::string::npos) << lonely.reason;
  source.Commit(source.PrepareFirst(0));
  // Against a given base frame: the registration to that one only.
  const CandidateFrame against = source.PrepareAgainst(1, 0);
  EXPECT_TRUE(against.registered);
  EXPECT_EQ(against.base_frame, 0);
}

}  // namespace
}  // namespace ieslam
