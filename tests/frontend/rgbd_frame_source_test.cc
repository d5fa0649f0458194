#include "frontend/rgbd_frame_source.h"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "core/calibration.h"
#include "frontend/simulation/synthetic_dataset.h"
#include "global_shutter_calibration.h"

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
  // 0, 4 and 6, and the frames next to them that the rolling shutter's velocities fetched.
  const int kept = source.frames_kept();
  EXPECT_GE(kept, 3);

  source.Release(4);
  EXPECT_EQ(source.frames_kept(), kept - 1);
  source.Release(0);  // the base frame stays
  EXPECT_EQ(source.frames_kept(), kept - 1);

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

// A frame's registrations to its base candidates run on registration_threads threads; any
// number gives the same candidate, bit for bit.
TEST(RgbdFrameSourceTest, RegistrationThreadsGiveTheSameCandidates) {
  const std::unique_ptr<Dataset> dataset = OpenDataset(kSevenScenes, DatasetOptions());
  std::vector<CandidateFrame> by_threads;
  for (int threads : {1, 3}) {
    RgbdSourceOptions options;
    options.registration_threads = threads;
    RgbdFrameSource source(*dataset, options);
    source.Commit(source.PrepareFirst(0));
    for (int frame : {4, 8, 12}) {
      const CandidateFrame c = source.Prepare(frame);
      ASSERT_TRUE(c.registered) << c.reason;
      source.Commit(c);
    }
    by_threads.push_back(source.Prepare(16));
  }
  const CandidateFrame& one = by_threads[0];
  const CandidateFrame& three = by_threads[1];
  ASSERT_TRUE(one.registered) << one.reason;
  EXPECT_EQ(three.base_frame, one.base_frame);
  EXPECT_TRUE(three.T_base_c.isApprox(one.T_base_c, 0.0));
  EXPECT_EQ(three.common_features, one.common_features);
  EXPECT_GT(one.common_features, 50);
  ASSERT_EQ(three.observations.size(), one.observations.size());
  for (size_t i = 0; i < one.observations.size(); ++i) {
    EXPECT_EQ(three.observations[i].feature_id, one.observations[i].feature_id);
    EXPECT_EQ(three.observations[i].z, one.observations[i].z);
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
  EXPECT_GE(source.frames_kept(), 3);
  source.Finish();
  EXPECT_EQ(source.frames_kept(), 0);
}

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// A rolling-shutter camera turning ~90 deg/s: each keypoint's lifted point is seen from its
// row's pose. Compensated with the velocity its registrations to its neighbours give, the
// point must land where that row's exact pose puts it, seen from the frame's exact pose.
TEST(RgbdFrameSourceTest, RollingShutterFramesAreSeenFromTheirTimestampsPose) {
  namespace fs = std::filesystem;
  const fs::path root =
      fs::temp_directory_path() / ("ieslam_rgbd_source_rs_test_" + std::to_string(::getpid()));
  SyntheticDatasetOptions synth;
  synth.frames = 10;
  synth.frames_per_loop = 150;  // twice the default's turning rate
  synth.resolution_scale = 0.5;
  synth.readout_s = 0.03;
  WriteSyntheticDataset((root / "rs").string(), synth);
  ASSERT_EQ(ReadCalibration((root / "rs" / "calib.yaml").string()).colour_readout_s, 0.03);

  const std::unique_ptr<Dataset> rolling = OpenDataset((root / "rs").string(), DatasetOptions());
  DatasetOptions as_global;
  as_global.calib_file =
      testing_files::WriteGlobalShutterCalibration(root / "rs", root / "global.yaml");
  const std::unique_ptr<Dataset> still = OpenDataset((root / "rs").string(), as_global);
  RgbdFrameSource compensating(*rolling, RgbdSourceOptions());
  RgbdFrameSource plain(*still, RgbdSourceOptions());
  ASSERT_NE(compensating.velocities(), nullptr);
  EXPECT_EQ(plain.velocities(), nullptr);

  std::vector<double> compensated_error, plain_error;
  for (int frame = 1; frame + 1 < rolling->size(); ++frame) {
    const ProcessedFrame& a = compensating.Processed(frame);
    const ProcessedFrame& b = plain.Processed(frame);
    ASSERT_EQ(a.points.size(), b.points.size());
    const Eigen::Isometry3d T_w_c = *rolling->info(frame).T_w_c_gt;
    for (size_t i = 0; i < a.points.size(); ++i) {
      const double tau = rolling->rig().RowTimeOffset(a.features.pixels[i].y());
      const Eigen::Isometry3d T_w_row = SyntheticTrajectoryPose(
          synth.trajectory, frame + tau * synth.frame_rate_hz, synth.frames_per_loop);
      const Eigen::Vector3d p_w = T_w_row * b.points[i].p_c;
      compensated_error.push_back((T_w_c * a.points[i].p_c - p_w).norm());
      plain_error.push_back((T_w_c * b.points[i].p_c - p_w).norm());
    }
  }
  fs::remove_all(root);
  ASSERT_GT(compensated_error.size(), 500u);
  EXPECT_GT(Median(plain_error), 0.004);
  EXPECT_LT(Median(compensated_error), 0.15 * Median(plain_error));
  const FrameVelocities::Counts& counts = compensating.velocities()->counts();
  EXPECT_EQ(counts.both, rolling->size() - 2);
  EXPECT_EQ(counts.none, 0);
}

}  // namespace
}  // namespace ieslam
