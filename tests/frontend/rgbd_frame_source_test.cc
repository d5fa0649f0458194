#include "frontend/rgbd_frame_source.h"

#include <memory>
#include <set>
#include <string>
#include <utility>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

const std::string kSevenScenes = std::string(IESLAM_SHARED_DATA_DIR) + "/7scenes-dev";

// SIFT gives a blob with several dominant orientations one keypoint per orientation, all at
// one position: one image measurement. The source must make them one feature observed once,
// or the filter counts that measurement twice and becomes overconfident.
TEST(RgbdFrameSourceTest, OrientationSiblingsAreOneFeatureObservedOnce) {
  const std::unique_ptr<Dataset> dataset = OpenDataset(kSevenScenes, DatasetOptions());
  RgbdSourceOptions options;
  options.max_new_features_per_frame = 1000000;  // every keypoint of the first frame
  RgbdFrameSource source(*dataset, options);

  std::set<std::pair<double, double>> pixels;
  const FrameFeatures& first = source.Processed(0).features;
  for (const Eigen::Vector2d& pixel : first.pixels) pixels.insert({pixel.x(), pixel.y()});
  ASSERT_LT(static_cast<int>(pixels.size()), first.size()) << "no siblings: nothing to test";

  const CandidateFrame origin = source.PrepareFirst(0);
  EXPECT_EQ(origin.observations.size(), pixels.size());
  source.Commit(origin);
  const CandidateFrame next = source.Prepare(5);
  ASSERT_TRUE(next.registered) << next.reason;
  EXPECT_GT(next.common_features, 50);

  for (const CandidateFrame* candidate : {&origin, &next}) {
    std::set<std::pair<double, double>> measured;
    std::set<int64_t> ids;
    for (const FeatureObservation& obs : candidate->observations) {
      EXPECT_TRUE(measured.insert({obs.z.x(), obs.z.y()}).second)
          << "frame " << candidate->frame << " observes (" << obs.z.x() << ", " << obs.z.y()
          << ") twice";
      EXPECT_TRUE(ids.insert(obs.feature_id).second)
          << "frame " << candidate->frame << " observes feature " << obs.feature_id << " twice";
    }
  }
}

// A released frame is freed and, prepared again, gives the same candidate from the frame
// processed anew; a base frame is never released.
TEST(RgbdFrameSourceTest, AReleasedFrameIsFreedAndPreparedAgainAlike) {
  const std::unique_ptr<Dataset> dataset = OpenDataset(kSevenScenes, DatasetOptions());
  RgbdFrameSource source(*dataset, RgbdSourceOptions());
  source.Commit(source.PrepareFirst(0));
  const CandidateFrame before = source.Prepare(4);
  ASSERT_TRUE(before.registered) << before.reason;
  source.Prepare(6);
  EXPECT_EQ(source.frames_kept(), 3);

  source.Release(4);
  EXPECT_EQ(source.frames_kept(), 2);
  source.Release(0);  // the base frame stays
  EXPECT_EQ(source.frames_kept(), 2);

  const CandidateFrame again = source.Prepare(4);
  ASSERT_TRUE(again.registered) << again.reason;
  EXPECT_EQ(again.base_frame, before.base_frame);
  EXPECT_TRUE(again.T_base_c.isApprox(before.T_base_c, 0.0));
  ASSERT_EQ(again.observations.size(), before.observations.size());
  for (size_t i = 0; i < again.observations.size(); ++i) {
    EXPECT_EQ(again.observations[i].feature_id, before.observations[i].feature_id);
    EXPECT_EQ(again.observations[i].z, before.observations[i].z);
    EXPECT_EQ(again.observations[i].Q, before.observations[i].Q);
  }
}

TEST(RgbdFrameSourceTest, FinishFreesEveryFrame) {
  const std::unique_ptr<Dataset> dataset = OpenDataset(kSevenScenes, DatasetOptions());
  RgbdFrameSource source(*dataset, RgbdSourceOptions());
  source.Commit(source.PrepareFirst(0));
  const CandidateFrame c = source.Prepare(4);
  ASSERT_TRUE(c.registered) << c.reason;
  source.Commit(c);
  source.Prepare(6);
  EXPECT_EQ(source.frames_kept(), 3);
  source.Finish();
  EXPECT_EQ(source.frames_kept(), 0);
}

}  // namespace
}  // namespace ieslam
