// InformationFilter's information gain of a candidate (backend/information_filter_gain.cc)
// against log det of the explicitly expanded matrix, sparse and dense.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "backend/dense_reference_filter.h"
#include "backend/filter_test_scene.h"
#include "backend/information_filter.h"
#include "core/error.h"

namespace ieslam {
namespace {

// Every test runs on both factorisations: the sparse one (max_dense_pose_dim 0) and the
// dense pose Schur complement.
class InformationFilterGainTest : public ::testing::TestWithParam<int> {
 protected:
  InformationFilterOptions DefaultOptions() const {
    InformationFilterOptions options;
    options.max_dense_pose_dim = GetParam();
    return options;
  }
};

INSTANTIATE_TEST_SUITE_P(Factorisations, InformationFilterGainTest, ::testing::Values(0, 2400),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return info.param == 0 ? std::string("Sparse")
                                                  : std::string("PoseSchur");
                         });

// The fast gain of a candidate against log det of the expanded matrix, sparse and dense, with
// the equal-dimension rule counting `count` entering features (negative: all); its terms add
// up to it.
void ExpectGainOfTheExpandedMatrix(const InformationFilter& sparse,
                                   const testing::DenseReferenceFilter& dense,
                                   const Vector6d& candidate,
                                   const std::vector<FeatureObservation>& observations, int count,
                                   const FeatureCovariance& known) {
  GainTerms terms;
  const double fast = sparse.InformationGain(candidate, observations, count, known, &terms);
  const double expanded =
      sparse.LogDetExpandedInformation(candidate, observations, count) - sparse.LogDetInformation();
  const int dense_count = count < 0 ? sparse.CountEnteringFeatures(observations) : count;
  const double paper =
      dense.LogDetExpanded(candidate, observations, dense_count) - dense.LogDetInformation();
  EXPECT_NEAR(fast, expanded, 1e-6 * std::abs(expanded)) << "counting " << count;
  EXPECT_NEAR(fast, paper, 1e-9 * std::abs(paper)) << "counting " << count;
  EXPECT_NEAR(terms.total(), fast, 1e-9 * std::abs(fast));
  EXPECT_GT(fast, 0.0);
}

// Candidates: the next poses of the scene, seen from perturbed registrations.
TEST_P(InformationFilterGainTest, FastGainEqualsLogDetOfTheExpandedMatrix) {
  for (const unsigned seed : {9u, 10u, 11u, 12u}) {
    std::mt19937 rng(seed);
    const int num_poses = 9;
    const Scene scene = MakeScene(num_poses, 100, &rng);
    InformationFilter sparse(DefaultOptions(), scene.camera);
    testing::DenseReferenceFilter dense(DefaultOptions().anchor_information, scene.camera);
    RunBoth(scene, 5, &rng, &sparse, &dense);

    std::vector<Vector6d> candidates;
    std::vector<std::vector<FeatureObservation>> observations;
    int min_new = std::numeric_limits<int>::max();
    std::vector<int64_t> union_ids;
    for (int i = 5; i < num_poses; ++i) {
      candidates.push_back(Perturb(scene.poses[i], 0.02, 0.01, &rng));
      observations.push_back(Observe(scene, i, true, &rng));
      min_new = std::min(min_new, sparse.CountNewFeatures(observations.back()));
      for (const FeatureObservation& obs : observations.back()) union_ids.push_back(obs.feature_id);
    }
    ASSERT_GT(min_new, 0);
    int max_new = 0;
    for (const auto& obs : observations) max_new = std::max(max_new, sparse.CountNewFeatures(obs));
    ASSERT_GT(max_new, min_new) << "the equal-dimension rule must drop some features";
    const FeatureCovariance known = sparse.JointFeatureCovariance(union_ids);
    for (size_t c = 0; c < candidates.size(); ++c) {
      for (const int count : {min_new, 0, -1}) {
        ExpectGainOfTheExpandedMatrix(sparse, dense, candidates[c], observations[c], count, known);
      }
    }
  }
}

TEST_P(InformationFilterGainTest, GainIsMinusInfinityWhenThePoseIsUndetermined) {
  std::mt19937 rng(13);
  const Scene scene = MakeScene(3, 50, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, false, &rng));
  std::vector<FeatureObservation> one_known;
  for (const FeatureObservation& obs : Observe(scene, 1, false, &rng)) {
    if (filter.HasFeature(obs.feature_id)) {
      one_known.push_back(obs);
      break;
    }
  }
  ASSERT_EQ(one_known.size(), 1u);
  const FeatureCovariance known = filter.JointFeatureCovariance({one_known[0].feature_id});
  EXPECT_EQ(filter.InformationGain(scene.poses[1], one_known, 0, known),
            -std::numeric_limits<double>::infinity());
}

// A candidate whose registration puts a known feature behind its camera, or whose
// observations are malformed, cannot be linearised: -infinity, not an exception.
TEST_P(InformationFilterGainTest, GainIsMinusInfinityWhenTheObservationsCannotBeLinearised) {
  std::mt19937 rng(19);
  const Scene scene = MakeScene(4, 60, &rng);
  InformationFilter filter(DefaultOptions(), scene.camera);
  filter.AddFirstPose(scene.frame_ids[0], scene.poses[0], Observe(scene, 0, false, &rng));
  filter.AddPose(scene.frame_ids[1], scene.poses[1], Observe(scene, 1, false, &rng));
  const std::vector<FeatureObservation> observations = Observe(scene, 2, false, &rng);
  std::vector<int64_t> ids;
  for (const FeatureObservation& obs : observations) ids.push_back(obs.feature_id);
  const FeatureCovariance known = filter.JointFeatureCovariance(ids);
  const int new_features = filter.CountNewFeatures(observations);
  GainTerms terms;
  ASSERT_TRUE(std::isfinite(
      filter.InformationGain(scene.poses[2], observations, new_features, known, &terms)));
  // Turned about its y axis by pi: every feature lies behind the camera.
  Vector6d turned = scene.poses[2];
  turned[4] += M_PI;
  GainTerms untouched = terms;
  EXPECT_EQ(filter.InformationGain(turned, observations, new_features, known, &untouched),
            -std::numeric_limits<double>::infinity());
  EXPECT_EQ(untouched.total(), terms.total());
  std::vector<FeatureObservation> doubled = observations;
  doubled.push_back(doubled.front());
  EXPECT_EQ(filter.InformationGain(scene.poses[2], doubled, new_features, known),
            -std::numeric_limits<double>::infinity());
  // Adding such a frame is refused, naming it.
  EXPECT_THROW(filter.AddPose(99, turned, observations), DataError);
}

// With delayed initialisation a candidate's gain counts the pending features it brings in,
// with their earlier sightings, and nothing for the sightings that leave a feature pending:
// against log det of the expanded matrix, sparse and dense, the equal-dimension rule
// counting the entering features. The covariance holds the earlier sightings' poses.
TEST_P(InformationFilterGainTest, GainCountsThePendingFeaturesACandidateBringsIn) {
  bool dropped = false;  // in some buffer, the equal-dimension rule left entering features out
  for (const unsigned seed : {9u, 10u, 11u, 12u, 13u}) {
    std::mt19937 rng(seed);
    const int num_poses = 9;
    const Scene scene = MakeScene(num_poses, 100, &rng);
    InformationFilterOptions options = DefaultOptions();
    options.min_sightings = 2;
    InformationFilter sparse(options, scene.camera);
    testing::DenseReferenceFilter dense(options.anchor_information, scene.camera, 2);
    RunBoth(scene, 5, &rng, &sparse, &dense);
    ASSERT_GT(sparse.num_pending_features(), 0);

    std::vector<Vector6d> candidates;
    std::vector<std::vector<FeatureObservation>> observations;
    int min_entering = std::numeric_limits<int>::max(), max_entering = 0;
    std::vector<int64_t> union_ids;
    std::vector<int> frames;
    for (int i = 5; i < num_poses; ++i) {
      candidates.push_back(Perturb(scene.poses[i], 0.02, 0.01, &rng));
      observations.push_back(Observe(scene, i, true, &rng));
      const int entering = sparse.CountEnteringFeatures(observations.back());
      min_entering = std::min(min_entering, entering);
      max_entering = std::max(max_entering, entering);
      for (const FeatureObservation& obs : observations.back()) union_ids.push_back(obs.feature_id);
      for (const int frame : sparse.EarlierSightingFrames(observations.back())) {
        frames.push_back(frame);
      }
      // A candidate's new features stay pending: they are not counted as entering.
      EXPECT_LT(entering, sparse.CountNewFeatures(observations.back()));
    }
    ASSERT_GT(min_entering, 0);
    dropped = dropped || max_entering > min_entering;
    const FeatureCovariance known = sparse.JointFeatureCovariance(union_ids, frames);
    for (size_t c = 0; c < candidates.size(); ++c) {
      for (const int count : {min_entering, 0, -1}) {
        ExpectGainOfTheExpandedMatrix(sparse, dense, candidates[c], observations[c], count, known);
      }
    }
  }
  EXPECT_TRUE(dropped) << "the equal-dimension rule must drop some features";
}

// The terms of a gain with pending features are those of the filter that would have held them
// since their first sightings: the same candidate, scored by a filter that adds every feature
// at once (min_sightings 1) over the same poses, has the same map term when both are linearised
// at the same points (noise-free observations at the true poses).
TEST_P(InformationFilterGainTest, MapTermCountsPendingFeaturesAsTheMaps) {
  std::mt19937 rng(17);
  const Scene scene = MakeScene(4, 80, &rng);
  InformationFilterOptions at_once = DefaultOptions(), delayed = DefaultOptions();
  delayed.min_sightings = 2;
  InformationFilter a(at_once, scene.camera), b(delayed, scene.camera);
  for (int i = 0; i < 3; ++i) {
    const std::vector<FeatureObservation> observations = Observe(scene, i, false, &rng);
    if (i == 0) {
      a.AddFirstPose(scene.frame_ids[0], scene.poses[0], observations);
      b.AddFirstPose(scene.frame_ids[0], scene.poses[0], observations);
    } else {
      a.AddPose(scene.frame_ids[i], scene.poses[i], observations);
      b.AddPose(scene.frame_ids[i], scene.poses[i], observations);
    }
  }
  ASSERT_GT(b.num_pending_features(), 0);
  // The candidate's observations of features both filters know of (no new ones: those add a
  // lone term to one filter and nothing to the other).
  std::vector<FeatureObservation> observations;
  std::vector<int64_t> ids;
  for (const FeatureObservation& obs : Observe(scene, 3, false, &rng)) {
    if (!a.HasFeature(obs.feature_id)) continue;
    observations.push_back(obs);
    ids.push_back(obs.feature_id);
  }
  ASSERT_GT(b.CountEnteringFeatures(observations), 0);
  GainTerms terms_a, terms_b;
  const double gain_a =
      a.InformationGain(scene.poses[3], observations, -1, a.JointFeatureCovariance(ids), &terms_a);
  const double gain_b = b.InformationGain(
      scene.poses[3], observations, -1,
      b.JointFeatureCovariance(ids, b.EarlierSightingFrames(observations)), &terms_b);
  EXPECT_NEAR(terms_b.map, terms_a.map, 1e-6 * std::abs(terms_a.map));
  EXPECT_NEAR(terms_b.pose, terms_a.pose, 1e-9 * std::abs(terms_a.pose));
  // The delayed filter gains the entering features' first sightings besides.
  EXPECT_NEAR(gain_b - terms_b.new_features, gain_a, 1e-6 * std::abs(gain_a));
}

}  // namespace
}  // namespace ieslam
