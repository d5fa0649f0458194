#include "backend/information_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "backend/dense_reference_filter.h"
#include "backend/filter_test_scene.h"
#include "core/error.h"

namespace ieslam {
namespace {

// The first two poses of `scene`, from noise-free observations.
void AddFirstTwoPoses(const Scene& scene, std::mt19937* rng, InformationFilter* filter) {
  filter->AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, false, rng));
  filter->AddPose(scene.frame_ids[1], scene.poses[1], Observe(scene, 1, false, rng));
}

// Every test runs on both factorisations: the sparse one (max_dense_pose_dim 0) and the
// dense pose Schur complement.
class InformationFilterTest : public ::testing::TestWithParam<int> {
 protected:
  // The paper's filter, every feature in the state from its first sighting (the dense
  // reference's); tests of delayed initialisation set min_sightings 2 themselves.
  InformationFilterOptions DefaultOptions() const {
    InformationFilterOptions options;
    options.max_dense_pose_dim = GetParam();
    options.min_sightings = 1;
    return options;
  }
};

INSTANTIATE_TEST_SUITE_P(Factorisations, InformationFilterTest, ::testing::Values(0, 2400),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return info.param == 0 ? std::string("Sparse")
                                                  : std::string("PoseSchur");
                         });

TEST_P(InformationFilterTest, OptionsCheckRejectsBadValues) {
  InformationFilterOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why)) << why;
  options.anchor_information = 0.0;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("anchor_information"), std::string::npos);
  options = InformationFilterOptions();
  options.min_known_features = 2;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_THROW(InformationFilter(options, TestCamera()), ConfigError);
}

TEST_P(InformationFilterTest, NoiseFreeObservationsRecoverTheExactScene) {
  std::mt19937 rng(1);
  const Scene scene = MakeScene(8, 60, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, false, &rng));
  for (int i = 1; i < 8; ++i) {
    filter.AddPose(scene.frame_ids[i], scene.poses[i], Observe(scene, i, false, &rng));
  }
  for (int i = 0; i < 8; ++i) {
    EXPECT_LT((filter.pose(scene.frame_ids[i]) - scene.poses[i]).norm(), 1e-6) << "pose " << i;
  }
  int seen = 0;
  for (size_t j = 0; j < scene.points.size(); ++j) {
    if (!filter.HasFeature(scene.feature_ids[j])) continue;
    ++seen;
    EXPECT_LT((filter.feature(scene.feature_ids[j]) - scene.points[j]).norm(), 1e-6);
  }
  EXPECT_GT(seen, 30);
  EXPECT_EQ(filter.state_dim(), 6 * 8 + 3 * seen);
  EXPECT_EQ(filter.num_features(), seen);
}

TEST_P(InformationFilterTest, LinearisedUpdateCorrectsAPerturbedInitialPose) {
  // Only one linearisation per pose (eq. 9), so the correction is first order: a 2 mm /
  // 1 mrad registration error leaves a residual error two orders of magnitude smaller.
  std::mt19937 rng(2);
  const Scene scene = MakeScene(6, 60, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, false, &rng));
  for (int i = 1; i < 6; ++i) {
    const Vector6d initial = Perturb(scene.poses[i], 0.002, 0.001, &rng);
    filter.AddPose(scene.frame_ids[i], initial, Observe(scene, i, false, &rng));
    EXPECT_LT((filter.pose(scene.frame_ids[i]) - scene.poses[i]).norm(),
              0.02 * (initial - scene.poses[i]).norm())
        << "pose " << i;
  }
}

TEST_P(InformationFilterTest, IdsAreStableAndStateIndicesConsistent) {
  std::mt19937 rng(3);
  const Scene scene = MakeScene(5, 50, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, false, &rng));
  const std::vector<int64_t> first_features = filter.feature_ids();
  for (int i = 1; i < 5; ++i) {
    filter.AddPose(scene.frame_ids[i], scene.poses[i], Observe(scene, i, false, &rng));
  }
  EXPECT_EQ(filter.frame_ids(), std::vector<int>(scene.frame_ids.begin(), scene.frame_ids.end()));
  ASSERT_GE(filter.feature_ids().size(), first_features.size());
  EXPECT_TRUE(
      std::equal(first_features.begin(), first_features.end(), filter.feature_ids().begin()))
      << "features keep their place in the order added";
  // Every id maps to its own block, and the blocks tile the state exactly.
  std::vector<int> covered(filter.state_dim(), 0);
  for (int id : filter.frame_ids()) {
    const int index = filter.StateIndex(VariableRef::Pose(id));
    for (int k = 0; k < 6; ++k) ++covered[index + k];
    EXPECT_EQ(filter.state().segment<6>(index), filter.pose(id));
  }
  for (int64_t id : filter.feature_ids()) {
    const int index = filter.StateIndex(VariableRef::Feature(id));
    for (int k = 0; k < 3; ++k) ++covered[index + k];
  }
  EXPECT_EQ(std::count(covered.begin(), covered.end(), 1), filter.state_dim());
}

TEST_P(InformationFilterTest, TooFewKnownFeaturesFailsCleanly) {
  std::mt19937 rng(4);
  const Scene scene = MakeScene(3, 50, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  AddFirstTwoPoses(scene, &rng, &filter);
  const int dim = filter.state_dim();
  const double log_det = filter.LogDetInformation();
  const Eigen::VectorXd state = filter.state();

  // Two known features and a few new ones.
  std::vector<FeatureObservation> observations;
  for (const FeatureObservation& obs : Observe(scene, 2, false, &rng)) {
    const bool known = filter.HasFeature(obs.feature_id);
    const int known_so_far = static_cast<int>(std::count_if(
        observations.begin(), observations.end(),
        [&](const FeatureObservation& o) { return filter.HasFeature(o.feature_id); }));
    if (!known || known_so_far < 2) observations.push_back(obs);
  }
  try {
    filter.AddPose(77, scene.poses[2], observations);
    FAIL() << "expected DataError";
  } catch (const DataError& error) {
    EXPECT_NE(std::string(error.what()).find("frame 77"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("observes 2 features"), std::string::npos)
        << error.what();
  }
  EXPECT_EQ(filter.state_dim(), dim);
  EXPECT_EQ(filter.num_poses(), 2);
  EXPECT_FALSE(filter.HasPose(77));
  EXPECT_EQ(filter.LogDetInformation(), log_det);
  EXPECT_EQ(filter.state(), state);

  // A taken frame id and a doubly observed feature are refused too.
  EXPECT_THROW(filter.AddPose(scene.frame_ids[1], scene.poses[2], Observe(scene, 2, false, &rng)),
               DataError);
  std::vector<FeatureObservation> doubled = Observe(scene, 2, false, &rng);
  doubled.push_back(doubled.front());
  EXPECT_THROW(filter.AddPose(78, scene.poses[2], doubled), DataError);
  // And the filter still works afterwards.
  filter.AddPose(scene.frame_ids[2], scene.poses[2], Observe(scene, 2, false, &rng));
  EXPECT_LT((filter.pose(scene.frame_ids[2]) - scene.poses[2]).norm(), 1e-6);
}

TEST_P(InformationFilterTest, InformationMatrixCouplesPosesOnlyThroughFeatures) {
  std::mt19937 rng(5);
  const Scene scene = MakeScene(4, 40, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, true, &rng));
  for (int i = 1; i < 4; ++i) {
    filter.AddPose(scene.frame_ids[i], scene.poses[i], Observe(scene, i, true, &rng));
  }
  const Eigen::MatrixXd I = Eigen::MatrixXd(filter.Information());
  EXPECT_LT((I - I.transpose()).norm(), 1e-12 * I.norm());
  for (int a : filter.frame_ids()) {
    for (int b : filter.frame_ids()) {
      if (a == b) continue;
      const int row = filter.StateIndex(VariableRef::Pose(a));
      const int col = filter.StateIndex(VariableRef::Pose(b));
      EXPECT_EQ(I.block(row, col, 6, 6).norm(), 0.0) << "frames " << a << ", " << b;
    }
  }
  const int64_t f0 = filter.feature_ids()[0], f1 = filter.feature_ids()[1];
  const int row = filter.StateIndex(VariableRef::Feature(f0));
  const int col = filter.StateIndex(VariableRef::Feature(f1));
  EXPECT_EQ(I.block(row, col, 3, 3).norm(), 0.0);
}

double RelativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / b.norm();
}

// The joint marginal covariance of a pose and a feature (blocks in that order) agrees with
// the dense reference's to 1e-9.
void ExpectJointMarginalMatchesDense(const InformationFilter& filter,
                                     const testing::DenseReferenceFilter& dense, int frame,
                                     int64_t feature) {
  std::vector<int> indices;
  for (int k = 0; k < 6; ++k) indices.push_back(dense.PoseIndex(frame) + k);
  for (int k = 0; k < 3; ++k) indices.push_back(dense.FeatureIndex(feature) + k);
  EXPECT_LT(RelativeDifference(filter.MarginalCovariance(
                                   {VariableRef::Pose(frame), VariableRef::Feature(feature)}),
                               dense.CovarianceOf(indices)),
            1e-9)
      << "pose " << frame << ", feature " << feature;
}

TEST_P(InformationFilterTest, AgreesWithTheDenseReferenceFilter) {
  for (const unsigned seed : {6u, 7u, 8u}) {
    std::mt19937 rng(seed);
    const int num_poses = 5 + static_cast<int>(seed % 3) * 2;
    const Scene scene = MakeScene(num_poses, 40 + 10 * static_cast<int>(seed % 3), &rng);
    InformationFilter sparse(DefaultOptions(), scene.camera);
    testing::DenseReferenceFilter dense(DefaultOptions().anchor_information, scene.camera);
    RunBoth(scene, num_poses, &rng, &sparse, &dense);
    ASSERT_EQ(sparse.state_dim(), dense.state_dim());
    for (int id : sparse.frame_ids()) {
      EXPECT_LT((sparse.pose(id) - dense.pose(id)).norm(), 1e-9) << "frame " << id;
      EXPECT_LT(RelativeDifference(
                    sparse.PoseCovariance(id),
                    dense.CovarianceOf({dense.PoseIndex(id), dense.PoseIndex(id) + 1,
                                        dense.PoseIndex(id) + 2, dense.PoseIndex(id) + 3,
                                        dense.PoseIndex(id) + 4, dense.PoseIndex(id) + 5})),
                1e-9)
          << "frame " << id;
    }
    for (int64_t id : sparse.feature_ids()) {
      EXPECT_LT((sparse.feature(id) - dense.feature(id)).norm(), 1e-9) << "feature " << id;
    }
    EXPECT_NEAR(sparse.LogDetInformation(), dense.LogDetInformation(),
                1e-9 * std::abs(dense.LogDetInformation()));
    // A joint marginal of the last pose and a feature, blocks in the order asked.
    ExpectJointMarginalMatchesDense(sparse, dense, sparse.frame_ids().back(),
                                    sparse.feature_ids()[sparse.feature_ids().size() / 2]);
  }
}

// Delayed initialisation (min_sightings 2): a feature's first sighting waits aside and the
// feature enters at its second with both, coupling the earlier pose with it. The filter is
// the dense reference given the same observations: poses, features, covariances, log det;
// the state holds the features seen twice, no others.
TEST_P(InformationFilterTest, DelayedInitialisationAgreesWithTheDenseReference) {
  for (const unsigned seed : {6u, 7u, 8u}) {
    std::mt19937 rng(seed);
    const int num_poses = 5 + static_cast<int>(seed % 3) * 2;
    const Scene scene = MakeScene(num_poses, 40 + 10 * static_cast<int>(seed % 3), &rng);
    InformationFilterOptions options = DefaultOptions();
    options.min_sightings = 2;
    InformationFilter sparse(options, scene.camera);
    testing::DenseReferenceFilter dense(options.anchor_information, scene.camera, 2);
    RunBoth(scene, num_poses, &rng, &sparse, &dense);
    ASSERT_EQ(sparse.state_dim(), dense.state_dim());
    ASSERT_EQ(sparse.num_pending_features(), dense.num_pending());
    ASSERT_GT(sparse.num_pending_features(), 0);
    for (int id : sparse.frame_ids()) {
      EXPECT_LT((sparse.pose(id) - dense.pose(id)).norm(), 1e-9) << "frame " << id;
    }
    for (int64_t id : sparse.feature_ids()) {
      EXPECT_LT((sparse.feature(id) - dense.feature(id)).norm(), 1e-9) << "feature " << id;
      EXPECT_FALSE(sparse.IsPending(id));
    }
    for (const PendingFeature& pending : sparse.PendingFeatures()) {
      EXPECT_FALSE(dense.HasFeature(pending.id));
      EXPECT_EQ(pending.sightings.size(), 1u);
    }
    EXPECT_NEAR(sparse.LogDetInformation(), dense.LogDetInformation(),
                1e-9 * std::abs(dense.LogDetInformation()));
    // The first pose with a feature that entered at its second sighting, jointly.
    ExpectJointMarginalMatchesDense(sparse, dense, sparse.frame_ids().front(),
                                    sparse.feature_ids().front());
    ExpectJointMarginalMatchesDense(sparse, dense, sparse.frame_ids().back(),
                                    sparse.feature_ids()[sparse.feature_ids().size() / 2]);
  }
}

// On noise-free observations at the true poses both filters recover the scene; delayed, the
// state is smaller by the features only one pose saw, which wait aside with that sighting.
TEST_P(InformationFilterTest, DelayedInitialisationLeavesSingleSightedFeaturesOut) {
  std::mt19937 rng(22);
  const int num_poses = 6;
  const Scene scene = MakeScene(num_poses, 80, &rng);
  InformationFilterOptions delayed_options = DefaultOptions();
  delayed_options.min_sightings = 2;
  InformationFilter at_once(DefaultOptions(), scene.camera), delayed(delayed_options, scene.camera);
  std::map<int64_t, int> sightings;
  for (int i = 0; i < num_poses; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, false, &rng);
    for (const FeatureObservation& obs : observations) ++sightings[obs.feature_id];
    for (InformationFilter* filter : {&at_once, &delayed}) {
      if (i == 0) {
        filter->AddFirstPose(scene.frame_ids[0], scene.poses[0], observations);
      } else {
        filter->AddPose(scene.frame_ids[i], scene.poses[i], observations);
      }
    }
  }
  int single = 0;
  for (const auto& [id, count] : sightings) {
    EXPECT_EQ(delayed.IsPending(id), count == 1) << "feature " << id;
    EXPECT_EQ(delayed.HasFeature(id), count > 1) << "feature " << id;
    single += count == 1 ? 1 : 0;
  }
  ASSERT_GT(single, 5);
  EXPECT_EQ(delayed.num_pending_features(), single);
  EXPECT_EQ(delayed.num_features(), at_once.num_features() - single);
  EXPECT_EQ(delayed.state_dim(), at_once.state_dim() - 3 * single);
  for (int i = 0; i < num_poses; ++i) {
    EXPECT_LT((delayed.pose(scene.frame_ids[i]) - scene.poses[i]).norm(), 1e-6) << "pose " << i;
  }
  for (int64_t id : delayed.feature_ids()) {
    EXPECT_LT((delayed.feature(id) - at_once.feature(id)).norm(), 1e-6) << "feature " << id;
  }
}

// A pose must be tied to the map by features in the state or entering with it; the pending
// ones it would only see again tie it as well. Refused, it leaves the pending features as
// they were.
TEST_P(InformationFilterTest, DelayedPoseNeedsFeaturesThatTieIt) {
  std::mt19937 rng(23);
  const Scene scene = MakeScene(3, 60, &rng);
  InformationFilterOptions options = DefaultOptions();
  options.min_sightings = 2;
  InformationFilter filter(options, scene.camera);
  filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, false, &rng));
  EXPECT_EQ(filter.state_dim(), 6);
  const int pending = filter.num_pending_features();
  ASSERT_GT(pending, 10);
  // Two of the first pose's features and the new ones: too few to tie the pose.
  std::vector<FeatureObservation> observations;
  int tying = 0;
  for (const FeatureObservation& obs : Observe(scene, 1, false, &rng)) {
    const bool ties = filter.IsPending(obs.feature_id);
    if (ties && tying == 2) continue;
    tying += ties ? 1 : 0;
    observations.push_back(obs);
  }
  ASSERT_EQ(tying, 2);
  EXPECT_THROW(filter.AddPose(scene.frame_ids[1], scene.poses[1], observations), DataError);
  EXPECT_EQ(filter.num_pending_features(), pending);
  EXPECT_EQ(filter.state_dim(), 6);
  // All of them tie it.
  filter.AddPose(scene.frame_ids[1], scene.poses[1], Observe(scene, 1, false, &rng));
  EXPECT_LT((filter.pose(scene.frame_ids[1]) - scene.poses[1]).norm(), 1e-6);
  EXPECT_GT(filter.num_features(), 10);
}

// Past max_dense_pose_dim the sparse factor takes over in the middle of a run; the filter
// stays the dense one.
TEST_P(InformationFilterTest, SwitchingFactorisationMidwayChangesNothing) {
  std::mt19937 rng(21);
  const int num_poses = 8;
  const Scene scene = MakeScene(num_poses, 60, &rng);
  InformationFilterOptions options = DefaultOptions();
  options.max_dense_pose_dim = 24;  // four poses
  InformationFilter filter(options, scene.camera);
  testing::DenseReferenceFilter dense(options.anchor_information, scene.camera);
  RunBoth(scene, 4, &rng, &filter, &dense);
  EXPECT_TRUE(filter.uses_pose_schur());
  for (int i = 4; i < num_poses; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, true, &rng);
    const Vector6d initial = Perturb(scene.poses[i], 0.02, 0.01, &rng);
    filter.AddPose(scene.frame_ids[i], initial, observations);
    dense.AddPose(scene.frame_ids[i], initial, observations);
  }
  EXPECT_FALSE(filter.uses_pose_schur());
  for (int id : filter.frame_ids()) {
    EXPECT_LT((filter.pose(id) - dense.pose(id)).norm(), 1e-9) << "frame " << id;
  }
  EXPECT_NEAR(filter.LogDetInformation(), dense.LogDetInformation(),
              1e-9 * std::abs(dense.LogDetInformation()));
}

TEST_P(InformationFilterTest, OptionsCheckRejectsANegativeSpareCapacity) {
  InformationFilterOptions options;
  options.spare_capacity = -0.1;
  std::string why;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("spare_capacity"), std::string::npos) << why;
}

// In-place updates of the factor and the ordering are a matter of speed only: a full
// factorisation at every update, updates in place (new variables in spare slots), and
// every ordering method give the same filter, and that filter is the dense one.
TEST_P(InformationFilterTest, InPlaceUpdatesAndOrderingDoNotChangeTheResult) {
  std::mt19937 rng(14);
  const int num_poses = 9;
  const Scene scene = MakeScene(num_poses, 70, &rng);
  struct Variant {
    FillReducingOrdering ordering;
    double spare_capacity;
  };
  const std::vector<Variant> variants = {
      {FillReducingOrdering::kMetis, 0.0},   {FillReducingOrdering::kMetis, 100.0},
      {FillReducingOrdering::kAmd, 100.0},   {FillReducingOrdering::kNatural, 0.0},
      {FillReducingOrdering::kNatural, 1.0}, {FillReducingOrdering::kCholmodChoice, 0.5}};
  std::vector<std::unique_ptr<InformationFilter>> filters;
  for (const Variant& variant : variants) {
    InformationFilterOptions options = DefaultOptions();
    options.ordering = variant.ordering;
    options.spare_capacity = variant.spare_capacity;
    options.max_dense_pose_dim = 0;
    filters.push_back(std::make_unique<InformationFilter>(options, scene.camera));
  }
  filters.push_back(std::make_unique<InformationFilter>(DefaultOptions(), scene.camera));
  testing::DenseReferenceFilter dense(DefaultOptions().anchor_information, scene.camera);
  const std::vector<FeatureObservation> first = Observe(scene, 0, true, &rng);
  for (auto& filter : filters) filter->AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  dense.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  for (int i = 1; i < num_poses; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, true, &rng);
    const Vector6d initial = Perturb(scene.poses[i], 0.02, 0.01, &rng);
    for (auto& filter : filters) filter->AddPose(scene.frame_ids[i], initial, observations);
    dense.AddPose(scene.frame_ids[i], initial, observations);
    for (const auto& filter : filters) {
      ASSERT_EQ(filter->state_dim(), dense.state_dim());
      const int last = scene.frame_ids[i];
      EXPECT_LT((filter->pose(last) - dense.pose(last)).norm(), 1e-9) << "pose " << i;
      EXPECT_NEAR(filter->LogDetInformation(), dense.LogDetInformation(),
                  1e-9 * std::abs(dense.LogDetInformation()));
    }
  }
  for (const auto& filter : filters) {
    for (int64_t id : filter->feature_ids()) {
      EXPECT_LT((filter->feature(id) - dense.feature(id)).norm(), 1e-9) << "feature " << id;
    }
  }
}

// Lazy refactoring (the state by conjugate gradients between exact factorisations) is a
// matter of speed only: through a trajectory that comes back over its start (a loop
// closure: the last poses re-observe the first poses' features), every state agrees with
// refactoring at every update, and the state, log det and covariances with the dense filter.
// With cg_tolerance at double precision's floor (1e-10) to 1e-9 absolute; with the default,
// the error's Mahalanobis norm (under the dense information matrix) stays below the
// tolerance, i.e. each component within that many of its standard deviations. With features
// entering at their first sighting, and delayed to their second (which changes the earlier
// poses' blocks of S, and the couplings CG streams, as well).
class InformationFilterLazyTest : public ::testing::TestWithParam<int> {};

INSTANTIATE_TEST_SUITE_P(Sightings, InformationFilterLazyTest, ::testing::Values(1, 2),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return info.param == 1 ? std::string("AtFirstSighting")
                                                  : std::string("Delayed");
                         });

TEST_P(InformationFilterLazyTest, AgreesWithRefactoringEveryUpdateThroughALoopClosure) {
  std::mt19937 rng(31);
  Scene scene = MakeScene(12, 90, &rng);
  for (int i = 11; i >= 0; --i) {
    scene.frame_ids.push_back(1000 + i);
    Vector6d pose = scene.poses[i];
    pose[1] += 0.15;
    pose[3] += 0.02;
    scene.poses.push_back(pose);
  }
  const int num_poses = static_cast<int>(scene.poses.size());
  InformationFilterOptions default_options;
  default_options.cg_flop_weight = 0.0;  // lazy whenever it may be
  default_options.min_sightings = GetParam();
  InformationFilterOptions lazy_options = default_options;
  lazy_options.cg_tolerance = 1e-10;
  InformationFilterOptions exact_options;
  exact_options.iterative_recovery = false;
  exact_options.min_sightings = GetParam();
  InformationFilter lazy(lazy_options, scene.camera), exact(exact_options, scene.camera);
  InformationFilter by_default(default_options, scene.camera);
  testing::DenseReferenceFilter dense(exact_options.anchor_information, scene.camera, GetParam());
  const std::vector<FeatureObservation> first = Observe(scene, 0, true, &rng);
  lazy.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  exact.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  by_default.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  dense.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  int iterative = 0, default_iterative = 0;
  for (int i = 1; i < num_poses; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, true, &rng);
    const Vector6d initial = Perturb(scene.poses[i], 0.02, 0.01, &rng);
    lazy.AddPose(scene.frame_ids[i], initial, observations);
    exact.AddPose(scene.frame_ids[i], initial, observations);
    by_default.AddPose(scene.frame_ids[i], initial, observations);
    dense.AddPose(scene.frame_ids[i], initial, observations);
    iterative += lazy.last_timings().cg_iterations > 0 ? 1 : 0;
    default_iterative += by_default.last_timings().cg_iterations > 0 ? 1 : 0;
    EXPECT_EQ(exact.last_timings().cg_iterations, 0);
    EXPECT_LT((lazy.state() - exact.state()).norm(), 1e-9) << "pose " << i;
    // The default's error, laid out as the dense filter's state.
    Eigen::VectorXd error(dense.state_dim());
    for (int id : exact.frame_ids()) {
      error.segment<6>(dense.PoseIndex(id)) = by_default.pose(id) - exact.pose(id);
    }
    for (int64_t id : exact.feature_ids()) {
      error.segment<3>(dense.FeatureIndex(id)) = by_default.feature(id) - exact.feature(id);
    }
    EXPECT_LT(std::sqrt(error.dot(dense.information() * error)), default_options.cg_tolerance)
        << "pose " << i;
  }
  EXPECT_GT(iterative, num_poses / 3);          // the others: refactoring was as cheap
  EXPECT_GT(default_iterative, num_poses / 3);  // the default's bound was checked on CG states
  for (int id : lazy.frame_ids()) {
    EXPECT_LT((lazy.pose(id) - dense.pose(id)).norm(), 1e-9) << "frame " << id;
  }
  for (int64_t id : lazy.feature_ids()) {
    EXPECT_LT((lazy.feature(id) - dense.feature(id)).norm(), 1e-9) << "feature " << id;
  }
  EXPECT_NEAR(lazy.LogDetInformation(), dense.LogDetInformation(),
              1e-9 * std::abs(dense.LogDetInformation()));
  // The first pose of the loop and a feature of its start, jointly.
  ExpectJointMarginalMatchesDense(lazy, dense, scene.frame_ids[1], lazy.feature_ids()[2]);
}

TEST_P(InformationFilterTest, SameInputsGiveABitIdenticalState) {
  std::mt19937 rng_a(15), rng_b(15);
  const Scene scene = MakeScene(7, 60, &rng_a);
  MakeScene(7, 60, &rng_b);
  InformationFilter a(DefaultOptions(), scene.camera), b(DefaultOptions(), scene.camera);
  testing::DenseReferenceFilter dense_a(1.0, scene.camera), dense_b(1.0, scene.camera);
  RunBoth(scene, 7, &rng_a, &a, &dense_a);
  RunBoth(scene, 7, &rng_b, &b, &dense_b);
  EXPECT_EQ(a.state(), b.state());
  EXPECT_EQ(a.LogDetInformation(), b.LogDetInformation());
}

// The joint covariance of every feature at once (the forward-solve formula, with the rows
// outside the elimination paths dropped) against the dense inverse.
TEST_P(InformationFilterTest, JointCovarianceOfAllFeaturesMatchesTheDenseInverse) {
  std::mt19937 rng(16);
  const Scene scene = MakeScene(7, 60, &rng);
  InformationFilter sparse(DefaultOptions(), scene.camera);
  testing::DenseReferenceFilter dense(DefaultOptions().anchor_information, scene.camera);
  RunBoth(scene, 7, &rng, &sparse, &dense);
  // Reversed, with an unknown id and a repeat, which are skipped.
  std::vector<int64_t> ids(sparse.feature_ids().rbegin(), sparse.feature_ids().rend());
  ids.push_back(-5);
  ids.push_back(ids.front());
  const FeatureCovariance joint = sparse.JointFeatureCovariance(ids);
  ASSERT_EQ(joint.feature_ids.size(), sparse.feature_ids().size());
  std::vector<int> indices;
  for (int64_t id : joint.feature_ids) {
    for (int k = 0; k < 3; ++k) indices.push_back(dense.FeatureIndex(id) + k);
  }
  EXPECT_LT(RelativeDifference(joint.covariance, dense.CovarianceOf(indices)), 1e-9);
  EXPECT_EQ(joint.covariance, joint.covariance.transpose());
}

// Deferred recovery (batch loading) with exact linearisation points gives the step-by-step
// filter: noise-free observations at the true poses linearise both at the truth.
TEST_P(InformationFilterTest, DeferredRecoveryMatchesStepByStepAtExactLinearisationPoints) {
  std::mt19937 rng(17);
  const Scene scene = MakeScene(6, 60, &rng);
  InformationFilter step(DefaultOptions(), scene.camera), batch(DefaultOptions(), scene.camera);
  batch.set_defer_recovery(true);
  RunBothAtTheTruth(scene, 6, &rng, &step, &batch);
  EXPECT_TRUE(batch.recovery_pending());
  batch.Recover();
  EXPECT_FALSE(batch.recovery_pending());
  ASSERT_EQ(batch.state_dim(), step.state_dim());
  EXPECT_LT((batch.state() - step.state()).norm(), 1e-9);
  EXPECT_NEAR(batch.LogDetInformation(), step.LogDetInformation(),
              1e-9 * std::abs(step.LogDetInformation()));
  // Back to step-by-step updates afterwards.
  batch.set_defer_recovery(false);
  const std::vector<FeatureObservation> more = Observe(scene, 5, false, &rng);
  EXPECT_THROW(batch.AddPose(scene.frame_ids[5], scene.poses[5], more), DataError);
}

// Frame `i`'s noise-free observations with the one of `feature_id` moved by `pixels` in u.
std::vector<FeatureObservation> ObserveWithOneWrong(const Scene& scene, int i, int64_t feature_id,
                                                    double pixels, std::mt19937* rng) {
  std::vector<FeatureObservation> observations = Observe(scene, i, false, rng);
  bool planted = false;
  for (FeatureObservation& obs : observations) {
    if (obs.feature_id != feature_id) continue;
    obs.z.x() += pixels;
    planted = true;
  }
  EXPECT_TRUE(planted) << "frame " << i << " does not see feature " << feature_id;
  return observations;
}

// A feature every pose of the scene's first `num_poses` sees.
int64_t FeatureSeenByAll(const Scene& scene, int num_poses, std::mt19937* rng) {
  std::map<int64_t, int> seen;
  for (int i = 0; i < num_poses; ++i) {
    for (const FeatureObservation& obs : Observe(scene, i, false, rng)) ++seen[obs.feature_id];
  }
  for (const auto& [id, count] : seen) {
    if (count == num_poses) return id;
  }
  ADD_FAILURE() << "no feature is seen by every pose";
  return -1;
}

// Two filters over the same variables: the same state and log det, to rounding.
void ExpectSameEstimate(const InformationFilter& a, const InformationFilter& b) {
  ASSERT_EQ(a.state_dim(), b.state_dim());
  EXPECT_LT((a.state() - b.state()).norm(), 1e-9);
  EXPECT_NEAR(a.LogDetInformation(), b.LogDetInformation(), 1e-9 * std::abs(b.LogDetInformation()));
}

// The (frame, feature) of each observation `filter` withdrew.
std::set<std::pair<int, int64_t>> Withdrawn(const InformationFilter& filter) {
  std::set<std::pair<int, int64_t>> withdrawn;
  for (const TakenObservation& taken : filter.taken_observations()) {
    if (taken.withdrawn) withdrawn.insert({taken.frame_id, taken.observation.feature_id});
  }
  return withdrawn;
}

// Every frame of the scene's first `num_poses`, noise-free but for frame 2's observation of
// `wrong`, 25 px off in u, at the true poses; the observations in `left_out` are not taken.
void AddWithOneWrong(const Scene& scene, int num_poses, int64_t wrong,
                     const std::set<std::pair<int, int64_t>>& left_out, std::mt19937* rng,
                     InformationFilter* filter) {
  for (int i = 0; i < num_poses; ++i) {
    std::vector<FeatureObservation> observations =
        i == 2 ? ObserveWithOneWrong(scene, i, wrong, 25.0, rng) : Observe(scene, i, false, rng);
    std::vector<FeatureObservation> taken;
    for (const FeatureObservation& obs : observations) {
      if (left_out.count({scene.frame_ids[i], obs.feature_id}) == 0) taken.push_back(obs);
    }
    if (i == 0) {
      filter->AddFirstPose(scene.frame_ids[i], scene.poses[i], taken);
    } else {
      filter->AddPose(scene.frame_ids[i], scene.poses[i], taken);
    }
  }
}

// Withdrawing is exact in information form: with every frame linearised at the same points
// (deferred recovery at the true poses), the filter that took observations and then withdrew
// them is the filter that never took them, to rounding; also where features enter at their
// second sighting, coupling with the earlier pose in their own columns. The wrong one is among
// them; so may be a few right ones of its frame, which it pulled past the gate with the pose.
TEST_P(InformationFilterTest, WithdrawingObservationsUndoesThemExactly) {
  for (const int sightings : {1, 2}) {
    SCOPED_TRACE("min_sightings " + std::to_string(sightings));
    std::mt19937 rng(31);
    const int num_poses = 6;
    const Scene scene = MakeScene(num_poses, 60, &rng);
    const int64_t wrong = FeatureSeenByAll(scene, num_poses, &rng);
    InformationFilterOptions options = DefaultOptions();
    options.min_sightings = sightings;
    InformationFilter with(options, scene.camera), without(options, scene.camera);
    with.set_defer_recovery(true);
    AddWithOneWrong(scene, num_poses, wrong, {}, &rng, &with);
    with.Recover();
    const double log_det_before = with.LogDetInformation();
    const WithdrawalStatistics stats = with.WithdrawInconsistent();
    EXPECT_EQ(stats.put_back, 0);
    EXPECT_EQ(stats.tested, static_cast<int>(with.taken_observations().size()));
    const std::set<std::pair<int, int64_t>> withdrawn = Withdrawn(with);
    EXPECT_EQ(static_cast<int>(withdrawn.size()), stats.withdrawn);
    EXPECT_EQ(withdrawn.count({scene.frame_ids[2], wrong}), 1u);
    EXPECT_LE(withdrawn.size(), 4u) << "of " << stats.tested;

    without.set_defer_recovery(true);
    AddWithOneWrong(scene, num_poses, wrong, withdrawn, &rng, &without);
    without.Recover();
    ExpectSameEstimate(with, without);
    EXPECT_LT(with.LogDetInformation(), log_det_before);
    const int last = scene.frame_ids.back();
    EXPECT_LT(RelativeDifference(with.PoseCovariance(last), without.PoseCovariance(last)), 1e-9);
    // Updates go on from the filter without them.
    const std::vector<FeatureObservation> more = Observe(scene, 1, false, &rng);
    with.set_defer_recovery(false);
    without.set_defer_recovery(false);
    with.AddPose(999, scene.poses[1], more);
    without.AddPose(999, scene.poses[1], more);
    EXPECT_LT((with.state() - without.state()).norm(), 1e-9);
  }
}

// A wrong first sighting: no gate can test it when it enters, as its feature is new. At the
// end the feature's later sightings outvote it, and it is withdrawn; the right observations,
// with noise as stated, stay.
TEST_P(InformationFilterTest, WithdrawsAWrongFirstSightingAndKeepsTheRightOnes) {
  std::mt19937 rng(32);
  const int num_poses = 8;
  const Scene scene = MakeScene(num_poses, 60, &rng);
  const int64_t wrong = FeatureSeenByAll(scene, num_poses, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  std::vector<FeatureObservation> first = Observe(scene, 0, true, &rng);
  for (FeatureObservation& obs : first) {
    if (obs.feature_id == wrong) obs.z.x() += 20.0;  // 40 sigma
  }
  filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  for (int i = 1; i < num_poses; ++i) {
    filter.AddPose(scene.frame_ids[i], Perturb(scene.poses[i], 0.02, 0.01, &rng),
                   Observe(scene, i, true, &rng));
  }
  const Eigen::Vector3d truth = scene.points[(wrong - 1000) / 7];
  const double error_before = (filter.feature(wrong) - truth).norm();
  const WithdrawalStatistics stats = filter.WithdrawInconsistent();
  int withdrawn = 0;
  bool wrong_withdrawn = false;
  for (const TakenObservation& taken : filter.taken_observations()) {
    if (!taken.withdrawn) continue;
    ++withdrawn;
    wrong_withdrawn = wrong_withdrawn || (taken.frame_id == scene.frame_ids[0] &&
                                          taken.observation.feature_id == wrong);
  }
  EXPECT_TRUE(wrong_withdrawn);
  EXPECT_EQ(withdrawn, stats.withdrawn);
  // A right observation fails the gate once in a thousand.
  EXPECT_LE(withdrawn, 2) << "of " << stats.tested;
  EXPECT_LT((filter.feature(wrong) - truth).norm(), error_before / 4);

  // Without the gate nothing is tested.
  InformationFilterOptions no_gate = DefaultOptions();
  no_gate.gate_chi2 = 0.0;
  InformationFilter ungated(no_gate, scene.camera);
  ungated.AddFirstPose(scene.frame_ids[0], scene.poses[0], first);
  ungated.AddPose(scene.frame_ids[1], scene.poses[1], Observe(scene, 1, true, &rng));
  EXPECT_EQ(ungated.WithdrawInconsistent().tested, 0);
}

// Frames 0 .. num_poses - 1 of `scene`, noise-free but for frame 0's observation of `wrong`,
// 0.3 m off in range, at the true poses; the observations in `weightless` are taken with
// their Q times 1e14, which weighs them out and keeps every linearisation point.
void AddWithWrongRange(const Scene& scene, int num_poses, int64_t wrong,
                       const std::set<std::pair<int, int64_t>>& weightless, std::mt19937* rng,
                       InformationFilter* filter) {
  for (int i = 0; i < num_poses; ++i) {
    std::vector<FeatureObservation> observations = Observe(scene, i, false, rng);
    for (FeatureObservation& obs : observations) {
      if (i == 0 && obs.feature_id == wrong) obs.z.z() += 0.3;
      if (weightless.count({scene.frame_ids[i], obs.feature_id}) > 0) obs.Q *= 1e14;
    }
    if (i == 0) {
      filter->AddFirstPose(scene.frame_ids[i], scene.poses[i], observations);
    } else {
      filter->AddPose(scene.frame_ids[i], scene.poses[i], observations);
    }
  }
}

// Delayed initialisation: a feature enters at its second sighting with the first, which
// couples the earlier pose with it in the feature's own columns. Withdrawing that first
// sighting (the anchor's) and what it pulled past the gate leaves the filter that took them
// at no weight.
TEST_P(InformationFilterTest, WithdrawingAnEarlierSightingUndoesItExactly) {
  std::mt19937 rng(33);
  const int num_poses = 6;
  const Scene scene = MakeScene(num_poses, 60, &rng);
  const int64_t wrong = FeatureSeenByAll(scene, num_poses, &rng);
  InformationFilterOptions options = DefaultOptions();
  options.min_sightings = 2;
  InformationFilter with(options, scene.camera), weightless(options, scene.camera);
  with.set_defer_recovery(true);
  AddWithWrongRange(scene, num_poses, wrong, {}, &rng, &with);
  with.Recover();
  const WithdrawalStatistics stats = with.WithdrawInconsistent();
  const std::set<std::pair<int, int64_t>> withdrawn = Withdrawn(with);
  EXPECT_EQ(static_cast<int>(withdrawn.size()), stats.withdrawn);
  EXPECT_EQ(withdrawn.count({scene.frame_ids[0], wrong}), 1u);
  EXPECT_LE(withdrawn.size(), 3u);
  weightless.set_defer_recovery(true);
  AddWithWrongRange(scene, num_poses, wrong, withdrawn, &rng, &weightless);
  weightless.Recover();
  ExpectSameEstimate(with, weightless);
}

// A frame whose every observation of the map is wrong, each 40 px another way, and which
// alone sees some features of its own: withdrawing stops where the pose would lose its ties
// to the map (min_known_features of them stay), and the pose stays determined.
TEST_P(InformationFilterTest, WithdrawingLeavesEveryPoseTiedToTheMap) {
  std::mt19937 rng(34);
  const int num_poses = 6;
  const Scene scene = MakeScene(num_poses, 60, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  for (int i = 0; i < num_poses; ++i) {
    std::vector<FeatureObservation> observations = Observe(scene, i, false, &rng);
    if (i == 3) {
      const int count = static_cast<int>(observations.size());
      for (int j = 0; j < count; ++j) {
        FeatureObservation own = observations[j];
        own.feature_id += 1000000;
        if (j % 3 == 0) observations.push_back(own);
        observations[j].z.x() += j % 2 == 0 ? 40.0 : -40.0;
        observations[j].z.y() += j % 4 < 2 ? 40.0 : -40.0;
      }
      filter.AddPose(scene.frame_ids[i], scene.poses[i], observations);
    } else if (i == 0) {
      filter.AddFirstPose(scene.frame_ids[i], scene.poses[i], observations);
    } else {
      filter.AddPose(scene.frame_ids[i], scene.poses[i], observations);
    }
  }
  const WithdrawalStatistics stats = filter.WithdrawInconsistent();
  EXPECT_EQ(stats.put_back, 0);
  EXPECT_GT(stats.withdrawn, 0);
  EXPECT_GT(stats.still_failing, 0);  // the ties kept
  std::map<int64_t, int> kept_by_feature;
  for (const TakenObservation& taken : filter.taken_observations()) {
    if (!taken.withdrawn) ++kept_by_feature[taken.observation.feature_id];
  }
  int ties = 0;
  for (const TakenObservation& taken : filter.taken_observations()) {
    if (taken.frame_id == scene.frame_ids[3] && !taken.withdrawn &&
        kept_by_feature[taken.observation.feature_id] > 1) {
      ++ties;
    }
  }
  EXPECT_EQ(ties, DefaultOptions().min_known_features);
  const Matrix6d covariance = filter.PoseCovariance(scene.frame_ids[3]);
  EXPECT_TRUE(covariance.allFinite());
  EXPECT_LT(covariance.diagonal().maxCoeff(), 1.0);
}

// A filter restored from a snapshot holds no linearisation points of what it restored; what
// it takes after can be withdrawn, and the restored poses and features count as tied.
TEST_P(InformationFilterTest, ARestoredFilterWithdrawsWhatItTookAfter) {
  std::mt19937 rng(35);
  const int num_poses = 7;
  const Scene scene = MakeScene(num_poses, 60, &rng);
  const int64_t wrong = FeatureSeenByAll(scene, num_poses, &rng);
  InformationFilter before(DefaultOptions(), scene.camera);
  before.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, true, &rng));
  for (int i = 1; i < 4; ++i) {
    before.AddPose(scene.frame_ids[i], scene.poses[i], Observe(scene, i, true, &rng));
  }
  InformationFilter restored(DefaultOptions(), scene.camera);
  restored.Restore(before.Snapshot());
  EXPECT_TRUE(restored.taken_observations().empty());
  for (int i = 4; i < num_poses; ++i) {
    std::vector<FeatureObservation> observations = Observe(scene, i, true, &rng);
    for (FeatureObservation& obs : observations) {
      if (i == 5 && obs.feature_id == wrong) obs.z.y() += 20.0;
    }
    restored.AddPose(scene.frame_ids[i], scene.poses[i], observations);
  }
  const WithdrawalStatistics stats = restored.WithdrawInconsistent();
  EXPECT_EQ(stats.put_back, 0);
  EXPECT_EQ(Withdrawn(restored).count({scene.frame_ids[5], wrong}), 1u);
  EXPECT_LE(stats.withdrawn, 2) << "of " << stats.tested;
  for (const TakenObservation& taken : restored.taken_observations()) {
    EXPECT_GE(taken.frame_id, scene.frame_ids[4]);
  }
}

}  // namespace
}  // namespace ieslam
