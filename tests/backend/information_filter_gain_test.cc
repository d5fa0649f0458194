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
  // The paper's filter, every feature in the state from its first sighting (the dense
  // reference's); tests of delayed initialisation set min_sightings 2 themselves.
  InformationFilterOptions DefaultOptions() const {
    InformationFilterOptions options;
    options.max_dense_pose_dim = GetParam();
    options.min_sightings = 1;
    return options;
  }
};

INSTANTIATE_TEST_SUITE_P(Factorisations, InformationFilterGainTest, ::testing::Values(0, 2400),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return info.param == 0 ? std::string("Sparse")
                                                  : std::string("PoseSchur");
                         });

// The fast gain of a candidate against log det of the expanded matrix, sparse and dense, with
// the equal-dimension rule counting `count` features that no pose has seen (negative: all);
// without delayed initialisation its terms add up to it.
void ExpectGainOfTheExpandedMatrix(const InformationFilter& sparse,
                                   const testing::DenseReferenceFilter& dense,
                                   const Vector6d& candidate,
                                   const std::vector<FeatureObservation>& observations, int count,
                                   const FeatureCovariance& known) {
  GainTerms terms;
  const double fast = sparse.InformationGain(candidate, observations, count, known, &terms);
  const double expanded =
      sparse.LogDetExpandedInformation(candidate, observations, count) - sparse.LogDetInformation();
  const double paper =
      dense.LogDetExpanded(candidate, observations, count) - dense.LogDetInformation();
  EXPECT_NEAR(fast, expanded, 1e-6 * std::abs(expanded)) << "counting " << count;
  EXPECT_NEAR(fast, paper, 1e-9 * std::abs(paper)) << "counting " << count;
  if (sparse.options().min_sightings == 1) {
    EXPECT_NEAR(terms.total(), fast, 1e-9 * std::abs(fast));
  }
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
      min_new = std::min(min_new, sparse.CountFirstSightings(observations.back()));
      for (const FeatureObservation& obs : observations.back()) union_ids.push_back(obs.feature_id);
    }
    ASSERT_GT(min_new, 0);
    int max_new = 0;
    for (const auto& obs : observations) {
      max_new = std::max(max_new, sparse.CountFirstSightings(obs));
    }
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
  const int new_features = filter.CountFirstSightings(observations);
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

// With delayed initialisation a candidate's gain counts every pending feature it brings in,
// with its earlier sightings, and nothing for the features it is the first to see, which wait
// aside: against log det of the expanded matrix, sparse and dense, whatever the
// equal-dimension rule counts of those. Their own blocks go to the terms, as many as the rule
// counts. The covariance holds the earlier sightings' poses.
TEST_P(InformationFilterGainTest, GainCountsThePendingFeaturesACandidateBringsIn) {
  bool dropped = false;  // in some buffer, the equal-dimension rule left first sightings out
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
    int min_first = std::numeric_limits<int>::max(), max_first = 0;
    std::vector<int64_t> union_ids;
    std::vector<int> frames;
    for (int i = 5; i < num_poses; ++i) {
      candidates.push_back(Perturb(scene.poses[i], 0.02, 0.01, &rng));
      observations.push_back(Observe(scene, i, true, &rng));
      const int first = sparse.CountFirstSightings(observations.back());
      min_first = std::min(min_first, first);
      max_first = std::max(max_first, first);
      EXPECT_GT(sparse.CountEnteringFeatures(observations.back()), 0);
      for (const FeatureObservation& obs : observations.back()) union_ids.push_back(obs.feature_id);
      for (const int frame : sparse.EarlierSightingFrames(observations.back())) {
        frames.push_back(frame);
      }
    }
    ASSERT_GT(min_first, 0);
    dropped = dropped || max_first > min_first;
    const FeatureCovariance known = sparse.JointFeatureCovariance(union_ids, frames);
    for (size_t c = 0; c < candidates.size(); ++c) {
      for (const int count : {min_first, 0, -1}) {
        ExpectGainOfTheExpandedMatrix(sparse, dense, candidates[c], observations[c], count, known);
      }
      GainTerms none, some, all;
      const double gain_none =
          sparse.InformationGain(candidates[c], observations[c], 0, known, &none);
      const double gain_some =
          sparse.InformationGain(candidates[c], observations[c], min_first, known, &some);
      const double gain_all =
          sparse.InformationGain(candidates[c], observations[c], -1, known, &all);
      EXPECT_EQ(gain_some, gain_none);
      EXPECT_EQ(gain_all, gain_none);
      EXPECT_EQ(some.map, none.map);
      EXPECT_EQ(some.pose, none.pose);
      EXPECT_EQ(none.new_features, 0.0);
      EXPECT_GT(some.new_features, 0.0);
      if (sparse.CountFirstSightings(observations[c]) > min_first) {
        EXPECT_GT(all.new_features, some.new_features);
      }
    }
  }
  EXPECT_TRUE(dropped) << "the equal-dimension rule must drop some features";
}

// Two filters over the same poses, one adding every feature at once (min_sightings 1), the
// other at its second sighting, fed noise-free observations at the true poses so that both
// are linearised at the same points.
struct AtOnceAndDelayed {
  AtOnceAndDelayed(const InformationFilterOptions& options, const Scene& scene, int poses,
                   std::mt19937* rng)
      : a(options, scene.camera), b(Delayed(options), scene.camera) {
    RunBothAtTheTruth(scene, poses, rng, &a, &b);
  }
  static InformationFilterOptions Delayed(InformationFilterOptions options) {
    options.min_sightings = 2;
    return options;
  }
  InformationFilter a, b;
};

// The terms of a gain with delayed initialisation are those of the filter that would have
// held every feature since its first sighting, and their total is that filter's gain: the
// map term counts the pending features as the map's, the new features' term counts the
// features the candidate is the first to see, by the same equal-dimension rule.
TEST_P(InformationFilterGainTest, TermsAreThoseOfTheFilterHoldingEveryFeature) {
  std::mt19937 rng(17);
  const Scene scene = MakeScene(4, 80, &rng);
  const AtOnceAndDelayed f(DefaultOptions(), scene, 3, &rng);
  ASSERT_GT(f.b.num_pending_features(), 0);
  const std::vector<FeatureObservation> observations = Observe(scene, 3, false, &rng);
  std::vector<int64_t> ids;
  for (const FeatureObservation& obs : observations) ids.push_back(obs.feature_id);
  ASSERT_GT(f.b.CountEnteringFeatures(observations), 0);
  const int first = f.b.CountFirstSightings(observations);
  ASSERT_GT(first, 1);
  ASSERT_EQ(f.a.CountFirstSightings(observations), first);
  const FeatureCovariance known_a = f.a.JointFeatureCovariance(ids);
  const FeatureCovariance known_b =
      f.b.JointFeatureCovariance(ids, f.b.EarlierSightingFrames(observations));
  for (const int count : {-1, first / 2}) {
    SCOPED_TRACE("counting " + std::to_string(count));
    GainTerms terms_a, terms_b;
    const double gain_a =
        f.a.InformationGain(scene.poses[3], observations, count, known_a, &terms_a);
    const double gain_b =
        f.b.InformationGain(scene.poses[3], observations, count, known_b, &terms_b);
    EXPECT_NEAR(terms_b.map, terms_a.map, 1e-6 * std::abs(terms_a.map));
    EXPECT_NEAR(terms_b.pose, terms_a.pose, 1e-9 * std::abs(terms_a.pose));
    EXPECT_NEAR(terms_b.new_features, terms_a.new_features, 1e-9 * std::abs(terms_a.new_features));
    EXPECT_NEAR(terms_b.total(), gain_a, 1e-6 * std::abs(gain_a));
    // The delayed filter's own gain differs: it gains the entering features' first sightings
    // now, and nothing for the features that wait aside.
    EXPECT_GT(std::abs(gain_b - gain_a), 1.0);
  }
}

// A pending feature's covariance, and its covariances with the known features and the poses,
// are those the filter holding it since its first sighting has.
TEST_P(InformationFilterGainTest, PendingFeaturesCovarianceIsTheFilterHoldingThem) {
  std::mt19937 rng(23);
  const Scene scene = MakeScene(4, 80, &rng);
  const AtOnceAndDelayed f(DefaultOptions(), scene, 3, &rng);
  std::vector<int64_t> ids;
  int pending = 0;
  for (int i = 0; i < 3; ++i) {
    for (const FeatureObservation& obs : Observe(scene, i, false, &rng)) {
      if (std::find(ids.begin(), ids.end(), obs.feature_id) != ids.end()) continue;
      ids.push_back(obs.feature_id);
      pending += f.b.IsPending(obs.feature_id) ? 1 : 0;
    }
  }
  ASSERT_GT(pending, 1);
  ASSERT_LT(pending, static_cast<int>(ids.size()));
  const std::vector<int> frames = {scene.frame_ids[1], scene.frame_ids[2]};
  const FeatureCovariance ca = f.a.JointFeatureCovariance(ids, frames);
  const FeatureCovariance cb = f.b.JointFeatureCovariance(ids, frames);
  ASSERT_EQ(cb.feature_ids.size(), ids.size());
  const auto row_a = [&](int64_t id) { return 3 * ca.index.at(id); };
  const auto row_b = [&](int64_t id) { return 3 * cb.index.at(id); };
  const double scale = ca.covariance.diagonal().maxCoeff();
  for (const int64_t i : ids) {
    EXPECT_LT((f.b.MapFeature(i) - f.a.MapFeature(i)).norm(), 1e-9);
    for (const int64_t j : ids) {
      EXPECT_LT((cb.covariance.block<3, 3>(row_b(i), row_b(j)) -
                 ca.covariance.block<3, 3>(row_a(i), row_a(j)))
                    .cwiseAbs()
                    .maxCoeff(),
                1e-7 * scale)
          << i << ", " << j;
    }
    for (const int frame : frames) {
      EXPECT_LT((cb.covariance.block<3, 6>(row_b(i), cb.pose_row.at(frame)) -
                 ca.covariance.block<3, 6>(row_a(i), ca.pose_row.at(frame)))
                    .cwiseAbs()
                    .maxCoeff(),
                1e-7 * scale)
          << i << ", frame " << frame;
    }
  }
}

}  // namespace
}  // namespace ieslam
