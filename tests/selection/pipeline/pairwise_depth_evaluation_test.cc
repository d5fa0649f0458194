#include "selection/pipeline/pairwise_depth_evaluation.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>

#include <unistd.h>

#include "core/calibration.h"
#include "core/error.h"
#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

// Twelve frames of a turning camera whose range imager reads every depth tilted (a planted
// depth correction, as a miscalibrated Kinect's), with the calibration that knows it and one
// that does not.
class PairwiseDepthEvaluationTest : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() /
            ("ieslam_pairwise_depth_evaluation_test_" + std::to_string(::getpid()));
    SyntheticDatasetOptions options;
    options.frames = 12;
    options.frames_per_loop = 120;  // a few degrees a frame
    options.depth_correction = {-0.02, 0.01, 0.015};
    WriteSyntheticDataset((root_ / "tilted").string(), options);
    Rig unaware = ReadCalibration((root_ / "tilted" / "calib.yaml").string());
    unaware.range.depth_correction = {0.0, 0.0, 0.0};
    WriteCalibration((root_ / "unaware.yaml").string(), unaware);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  static DepthPairwiseReport Evaluate(bool aware) {
    DatasetOptions dataset_options;
    if (!aware) dataset_options.calib_file = (root_ / "unaware.yaml").string();
    const auto dataset = OpenDataset((root_ / "tilted").string(), dataset_options);
    PairwiseOptions options;
    options.step = 3;
    return EvaluatePairwiseDepthAlignment(*dataset, options, RangeCloudOptions(),
                                          DepthAlignmentOptions());
  }

  static fs::path root_;
};
fs::path PairwiseDepthEvaluationTest::root_;

// Read as it was taken, the depth's optimum is the truth to within the range noise; read
// without the tilt, the pairs move several times further from it, along the optical axis too.
TEST_F(PairwiseDepthEvaluationTest, AMiscalibratedDepthMovesEveryPairFromTheTruth) {
  const DepthPairwiseReport aware = Evaluate(true);
  const DepthPairwiseReport unaware = Evaluate(false);
  ASSERT_EQ(aware.pairs.size(), 9u);
  EXPECT_EQ(aware.pairs.front().frame_a, 0);
  EXPECT_EQ(aware.pairs.front().frame_b, 3);
  EXPECT_FALSE(aware.interrupted);
  EXPECT_EQ(aware.frames_without_ground_truth, 0);
  EXPECT_EQ(aware.success_rate, 1.0);
  EXPECT_EQ(unaware.success_rate, 1.0);
  std::cout << "translation error RMS (x, y, z) mm: as taken "
            << 1000 * aware.translation_error_rms_a.transpose() << ", without the tilt "
            << 1000 * unaware.translation_error_rms_a.transpose() << "\n";
  EXPECT_LT(aware.translation_error_rms_a.z(), 2.5e-3);
  EXPECT_GT(unaware.translation_error_rms_a.z(), 4.0 * aware.translation_error_rms_a.z());
  EXPECT_GT(unaware.translation_error_median_m, aware.translation_error_median_m);
}

TEST_F(PairwiseDepthEvaluationTest, TooFewFramesAndAStopRequest) {
  const auto dataset = OpenDataset((root_ / "tilted").string(), DatasetOptions());
  PairwiseOptions options;
  options.step = 12;
  EXPECT_THROW(EvaluatePairwiseDepthAlignment(*dataset, options, RangeCloudOptions(),
                                              DepthAlignmentOptions()),
               DataError);
  options.step = 3;
  int polls = 0;
  const DepthPairwiseReport stopped = EvaluatePairwiseDepthAlignment(
      *dataset, options, RangeCloudOptions(), DepthAlignmentOptions(), nullptr,
      [&polls] { return ++polls > 5; });
  EXPECT_TRUE(stopped.interrupted);
  ASSERT_EQ(stopped.pairs.size(), 2u);  // frames 0-4 loaded: pairs (0, 3) and (1, 4)
  EXPECT_EQ(stopped.pairs[1].frame_b, 4);
}

}  // namespace
}  // namespace ieslam
