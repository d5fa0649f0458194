#include "frontend/pairwise_evaluation.h"

#include <gtest/gtest.h>

#include <filesystem>

#include <unistd.h>

#include "core/dataset.h"
#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

class PairwiseEvaluationTest : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() /
           ("ieslam_pairwise_evaluation_test_" + std::to_string(::getpid()));
    SyntheticDatasetOptions options;
    options.frames = 6;
    options.frames_per_loop = 300;  // the first 6 frames of a 10 s loop, not a loop in 6
    WriteSyntheticDataset(dir_.string(), options);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static fs::path dir_;
};
fs::path PairwiseEvaluationTest::dir_;

// Frames are named by their index in the dataset, also after --first.
TEST_F(PairwiseEvaluationTest, RegistersEveryPairWithinTheGroundTruthLimits) {
  DatasetOptions from_second;
  from_second.first = 1;
  const auto dataset = OpenDataset(dir_.string(), from_second);
  PairwiseOptions options;
  options.step = 1;
  const PairwiseReport report = EvaluatePairwiseRegistration(*dataset, FrontendOptions(), options);
  EXPECT_FALSE(report.interrupted);
  ASSERT_EQ(report.pairs.size(), 4u);
  EXPECT_EQ(report.pairs[0].frame_a, 1);
  EXPECT_EQ(report.pairs[3].frame_a, 4);
  EXPECT_EQ(report.pairs[3].frame_b, 5);
  EXPECT_EQ(report.success_rate, 1.0);
  EXPECT_LT(report.translation_error_p90_m, 0.01);
  // Per axis in frame a's camera, over the successful pairs (all of them here): the squares
  // of the RMS add up to the mean squared error, and the mean is no larger than the RMS.
  double mean_square = 0.0;
  for (const PairRecord& pair : report.pairs) {
    mean_square += pair.translation_error_m * pair.translation_error_m / report.pairs.size();
  }
  EXPECT_NEAR(report.translation_error_rms_a.squaredNorm(), mean_square, 1e-15);
  EXPECT_TRUE((report.translation_error_mean_a.cwiseAbs().array() <=
               report.translation_error_rms_a.array() + 1e-15)
                  .all());
  EXPECT_GT(report.translation_error_rms_a.minCoeff(), 0.0);
}

// A stop request ends the evaluation; the report covers the pairs done.
TEST_F(PairwiseEvaluationTest, AStopRequestReportsThePairsDone) {
  const auto dataset = OpenDataset(dir_.string(), DatasetOptions());
  PairwiseOptions options;
  options.step = 1;
  int polls = 0;
  const PairwiseReport report = EvaluatePairwiseRegistration(
      *dataset, FrontendOptions(), options, nullptr, [&polls] { return ++polls > 3; });
  EXPECT_TRUE(report.interrupted);
  ASSERT_EQ(report.pairs.size(), 2u);  // frames 0, 1, 2 loaded: pairs (0, 1) and (1, 2)
  EXPECT_EQ(report.success_rate, 1.0);
  // Stopped before any pair: an empty report, not an error.
  const PairwiseReport none = EvaluatePairwiseRegistration(*dataset, FrontendOptions(), options,
                                                           nullptr, [] { return true; });
  EXPECT_TRUE(none.interrupted);
  EXPECT_TRUE(none.pairs.empty());
  EXPECT_EQ(none.success_rate, 0.0);
}

}  // namespace
}  // namespace ieslam
