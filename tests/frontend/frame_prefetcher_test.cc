// The prefetcher hands out exactly the frames the sequential path computes, in any request
// order, passes a bad image's error to the frame it belongs to, and shuts down cleanly.
#include "frontend/frame_prefetcher.h"

#include <cstring>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "core/error.h"
#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

class FramePrefetcherTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("ieslam_prefetcher_test_" + std::to_string(::getpid()));
    SyntheticDatasetOptions options;
    options.frames = 10;
    options.frames_per_loop = 300;
    options.resolution_scale = 0.5;
    WriteSyntheticDataset((root_ / "synthetic").string(), options);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  void SetUp() override {
    dataset_ = OpenDataset((root_ / "synthetic").string(), DatasetOptions());
    processor_ = std::make_unique<FrameProcessor>(dataset_->rig(), FrontendOptions());
  }

  // The sequential answer for `frame`.
  ProcessedFrame Expected(int frame) const { return processor_->Process(dataset_->Load(frame)); }

  static void ExpectSame(const ProcessedFrame& a, const ProcessedFrame& b) {
    ASSERT_EQ(a.info.index, b.info.index);
    ASSERT_EQ(a.features.size(), b.features.size());
    ASSERT_GT(a.features.size(), 20);
    ASSERT_EQ(a.points.size(), b.points.size());
    for (int i = 0; i < a.features.size(); ++i) {
      EXPECT_EQ(a.features.pixels[i], b.features.pixels[i]) << i;
      EXPECT_EQ(a.points[i].p_c, b.points[i].p_c) << i;
      EXPECT_EQ(a.points[i].Q, b.points[i].Q) << i;
    }
    const cv::Mat& da = a.features.descriptors;
    const cv::Mat& db = b.features.descriptors;
    ASSERT_EQ(da.size(), db.size());
    EXPECT_EQ(std::memcmp(da.data, db.data, da.total() * da.elemSize()), 0);
  }

  static fs::path root_;
  std::unique_ptr<Dataset> dataset_;
  std::unique_ptr<FrameProcessor> processor_;
};
fs::path FramePrefetcherTest::root_;

TEST_F(FramePrefetcherTest, RejectsBadOptions) {
  PrefetchOptions options;
  options.capacity = 0;
  EXPECT_THROW(FramePrefetcher(*dataset_, *processor_, options), ConfigError);
  options.capacity = 2;
  options.workers = -1;
  EXPECT_THROW(FramePrefetcher(*dataset_, *processor_, options), ConfigError);
}

TEST_F(FramePrefetcherTest, ThreadedFramesEqualSequentialOnes) {
  PrefetchOptions options;
  options.workers = 2;
  options.capacity = 3;
  FramePrefetcher prefetcher(*dataset_, *processor_, options);
  for (int frame = 0; frame < dataset_->size(); ++frame) {
    SCOPED_TRACE(frame);
    const PrefetchedFrame fetched = prefetcher.Take(frame);
    EXPECT_GT(fetched.seconds_load, 0.0);
    ExpectSame(fetched.processed, Expected(frame));
  }
}

TEST_F(FramePrefetcherTest, AnyRequestOrderGivesTheSameFrames) {
  PrefetchOptions options;
  options.workers = 1;
  options.capacity = 2;
  FramePrefetcher prefetcher(*dataset_, *processor_, options);
  // Jumps ahead past the window, goes back to dropped and taken frames, asks twice.
  for (int frame : {0, 1, 6, 2, 7, 7, 3, 9, 0}) {
    SCOPED_TRACE(frame);
    ExpectSame(prefetcher.Take(frame).processed, Expected(frame));
  }
}

TEST_F(FramePrefetcherTest, SequentialModeStartsNoThreadAndComputesOnDemand) {
  FramePrefetcher prefetcher(*dataset_, *processor_, PrefetchOptions());
  ExpectSame(prefetcher.Take(4).processed, Expected(4));
  EXPECT_EQ(prefetcher.seconds_waited(), 0.0);
}

TEST_F(FramePrefetcherTest, BadImageFailsItsOwnFrameOnly) {
  // A copy of the dataset with frame 3's colour image corrupted.
  const fs::path copy = root_ / "corrupt";
  fs::copy(root_ / "synthetic", copy,
           fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  const auto original = OpenDataset(copy.string(), DatasetOptions());
  const std::string bad = original->info(3).colour_path;
  std::ofstream(bad, std::ios::binary | std::ios::trunc) << "not a png";
  const auto dataset = OpenDataset(copy.string(), DatasetOptions());
  for (int workers : {0, 2}) {
    SCOPED_TRACE(workers);
    PrefetchOptions options;
    options.workers = workers;
    options.capacity = 4;
    FramePrefetcher prefetcher(*dataset, *processor_, options);
    EXPECT_EQ(prefetcher.Take(2).processed.info.index, 2);
    try {
      prefetcher.Take(3);
      ADD_FAILURE() << "frame 3 has a corrupt image";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
    EXPECT_EQ(prefetcher.Take(4).processed.info.index, 4);
  }
}

TEST_F(FramePrefetcherTest, StopsWithFramesInFlight) {
  PrefetchOptions options;
  options.workers = 3;
  options.capacity = 8;
  for (int round = 0; round < 3; ++round) {
    FramePrefetcher prefetcher(*dataset_, *processor_, options);
    if (round > 0) prefetcher.Take(round);
  }  // joins: the test would hang here otherwise
  SUCCEED();
}

}  // namespace
}  // namespace ieslam
