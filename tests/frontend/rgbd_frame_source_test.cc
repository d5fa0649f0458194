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

}  // namespace
}  // namespace ieslam
