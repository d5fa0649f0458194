// Localisation in a saved map, on synthetic sequences with exact ground truth: a map of one
// pass through the room, then a second pass along another path through the same room, a
// room the map has never seen, and a kidnap between the two.
#include "selection/pipeline/localization.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "core/calibration.h"
#include "frontend/simulation/synthetic_dataset.h"
#include "global_shutter_calibration.h"
#include "selection/pipeline/dataset_run.h"
#include "selection/pipeline/localization_outputs.h"
#include "two_passes.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

class LocalizationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("ieslam_localization_test_" + std::to_string(::getpid()));
    WriteSyntheticDataset((root_ / "first").string(), FirstPass());
    // A quarter of a frame's time later, so that no frame of it is a frame of the map.
    SyntheticDatasetOptions second = SecondPass();
    second.start_time_s += 0.25 / second.frame_rate_hz;
    WriteSyntheticDataset((root_ / "second").string(), second);
    SyntheticDatasetOptions elsewhere = FirstPass();
    elsewhere.frames = 6;
    elsewhere.scene.seed += 1;  // another room
    WriteSyntheticDataset((root_ / "elsewhere").string(), elsewhere);
    SyntheticDatasetOptions fast = FirstPass();
    fast.frames = 24;
    fast.frames_per_loop = 60;  // 6 deg a frame round the room: soon out of the first view
    WriteSyntheticDataset((root_ / "fast").string(), fast);

    RunOptions options;
    options.dataset = (root_ / "first").string();
    options.threads = 1;
    const auto dataset = OpenDataset(options.dataset, options.dataset_options);
    RunResult run = RunOnDataset(*dataset, options, {});
    ASSERT_TRUE(run.saved_map.has_value());
    fs::create_directories(root_ / "map");
    WriteSavedMap((root_ / "map").string(), *run.saved_map);
    map_ = new SavedMap(ReadSavedMap((root_ / "map").string()));
    frontend_ = options.Resolved().source.frontend;
    database_ = options.Resolved().source.database;
  }
  static void TearDownTestSuite() {
    delete map_;
    fs::remove_all(root_);
  }

  static std::unique_ptr<Dataset> Open(const std::string& name) {
    return OpenDataset((root_ / name).string(), DatasetOptions());
  }
  static LocalizeResult Localize(const Dataset& dataset, int workers = 0,
                                 const LocalizeOptions& options = {}) {
    RgbdSourceOptions source;
    source.frontend = frontend_;
    source.database = database_;
    source.prefetch.workers = workers;
    return LocalizeDataset(dataset, *map_, source, options, {});
  }

  static fs::path root_;
  static SavedMap* map_;
  static FrontendOptions frontend_;
  static DatabaseOptions database_;
};
fs::path LocalizationTest::root_;
SavedMap* LocalizationTest::map_ = nullptr;
FrontendOptions LocalizationTest::frontend_;
DatabaseOptions LocalizationTest::database_;

TEST_F(LocalizationTest, PlacesASecondPassInTheMapFrameWithinItsStatedUncertainty) {
  const auto second = Open("second");
  const LocalizeResult result = Localize(*second);
  ASSERT_EQ(result.frames.size(), 40u);
  EXPECT_EQ(result.localized, 40);
  EXPECT_GE(result.localized_by_map, 38);
  EXPECT_FALSE(result.interrupted);

  const MapFrameAlignment alignment = AlignMapToGroundTruth(*map_, false);
  ASSERT_TRUE(alignment.ok) << alignment.reason;
  EXPECT_EQ(alignment.keyframes, static_cast<int>(map_->keyframes.size()));
  EXPECT_LT(alignment.rmse_m, 0.01);  // the map's own error
  const LocalizeEvaluation evaluation = EvaluateLocalization(*second, result, alignment);
  ASSERT_TRUE(evaluation.ok) << evaluation.reason;
  EXPECT_EQ(evaluation.pairs, 40);
  // The map's error (a few mm) plus the fit's: well under a centimetre on exact data.
  EXPECT_LT(evaluation.ate_map_frame_m, 0.01);
  EXPECT_LT(evaluation.max_m, 0.02);
  // The stated covariance covers the error: the keyframe's uncertainty is in it.
  EXPECT_GE(evaluation.inside_2sigma, 0.8);
  for (const LocalizedFrame& f : result.frames) {
    EXPECT_TRUE(f.localized) << f.reason;
    EXPECT_GT(f.inliers, 30);
    EXPECT_GT(f.map_features, 0);
    EXPECT_GT(f.covariance.ldlt().vectorD().minCoeff(), 0.0);
  }
}

TEST_F(LocalizationTest, ARoomTheMapHasNotSeenIsNotPlacedAndEachFrameSaysWhy) {
  const auto elsewhere = Open("elsewhere");
  const LocalizeResult result = Localize(*elsewhere);
  EXPECT_EQ(result.localized, 0);
  ASSERT_EQ(result.frames.size(), 6u);
  for (const LocalizedFrame& f : result.frames) {
    EXPECT_FALSE(f.localized);
    EXPECT_NE(f.reason.find("frame " + std::to_string(f.frame)), std::string::npos) << f.reason;
  }
}

TEST_F(LocalizationTest, TrackingResumesWhenTheMapsViewReturnsAfterAKidnap) {
  const auto second = Open("second");
  const auto elsewhere = Open("elsewhere");
  const FrameProcessor processor(second->rig(), frontend_);
  MapLocalizer localizer(*map_, frontend_, database_, LocalizeOptions());
  for (int i = 0; i < 5; ++i) {
    const LocalizedFrame f = localizer.Localize(processor.Process(second->Load(i)));
    EXPECT_TRUE(f.localized && f.by_map) << f.reason;
  }
  for (int i = 0; i < 3; ++i) {  // kidnapped: neither the map nor the frame before places it
    const LocalizedFrame f = localizer.Localize(processor.Process(elsewhere->Load(i)));
    EXPECT_FALSE(f.localized);
  }
  const auto gt = second->info(30).T_w_c_gt;
  const LocalizedFrame back = localizer.Localize(processor.Process(second->Load(30)));
  ASSERT_TRUE(back.localized && back.by_map) << back.reason;
  const MapFrameAlignment alignment = AlignMapToGroundTruth(*map_, false);
  EXPECT_LT((back.T_map_c.translation() - (alignment.T_map_gt * *gt).translation()).norm(), 0.02);
}

TEST_F(LocalizationTest, TrackingBridgesFramesTheMapDoesNotPlaceAndItsChainIsBounded) {
  const auto fast = Open("fast");
  const FrameProcessor processor(fast->rig(), frontend_);
  // A map of the first keyframe alone, which the fast pass soon turns away from.
  SavedMap one = *map_;
  one.keyframes.resize(1);
  one.base_frames.resize(1);
  LocalizeOptions options;
  options.max_tracked_frames = 4;
  MapLocalizer localizer(one, frontend_, database_, options);
  int by_map = 0, tracked = 0, lost_after = -1;
  double last_trace = 0.0;
  for (int i = 0; i < fast->size() && lost_after < 0; ++i) {
    const LocalizedFrame f = localizer.Localize(processor.Process(fast->Load(i)));
    if (f.localized) {
      (f.by_map ? by_map : tracked) += 1;
      const double trace = f.covariance.topLeftCorner<3, 3>().trace();
      if (!f.by_map) {
        EXPECT_EQ(f.base_keyframe, -1);
        EXPECT_GT(trace, last_trace) << "a tracked frame's covariance grows along the chain";
      }
      last_trace = trace;
    } else {
      lost_after = i;
      EXPECT_NE(f.reason.find("tracking"), std::string::npos) << f.reason;
    }
  }
  EXPECT_GT(by_map, 0);
  EXPECT_EQ(tracked, 4);  // max_tracked_frames, then the chain ends
  EXPECT_GT(lost_after, 0);
}

TEST_F(LocalizationTest, WorkerThreadsDoNotChangeAPose) {
  const auto second = Open("second");
  const LocalizeResult a = Localize(*second, 0), b = Localize(*second, 2);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (size_t i = 0; i < a.frames.size(); ++i) {
    EXPECT_EQ(a.frames[i].localized, b.frames[i].localized);
    EXPECT_TRUE(a.frames[i].T_map_c.matrix() == b.frames[i].T_map_c.matrix()) << i;
    EXPECT_TRUE(a.frames[i].covariance == b.frames[i].covariance) << i;
  }
}

// A rolling-shutter second pass: each frame is compensated with the velocity of its
// registrations to the frames next to it, as the mapping run's are, and is placed as well as
// a global shutter's; read as a global shutter it is placed worse.
TEST_F(LocalizationTest, ARollingShutterPassIsCompensatedFrameByFrame) {
  SyntheticDatasetOptions rolling = SecondPass();
  rolling.start_time_s += 0.25 / rolling.frame_rate_hz;
  rolling.frames_per_loop = 150;  // ~75 deg/s
  rolling.frames = 30;
  rolling.readout_s = 0.03;
  WriteSyntheticDataset((root_ / "rolling").string(), rolling);
  DatasetOptions as_global;
  as_global.calib_file =
      testing_files::WriteGlobalShutterCalibration(root_ / "rolling", root_ / "global.yaml");

  const auto dataset = Open("rolling");
  const LocalizeResult compensated = Localize(*dataset);
  const LocalizeResult sheared = Localize(*OpenDataset((root_ / "rolling").string(), as_global));
  ASSERT_TRUE(compensated.velocity_counts);
  EXPECT_EQ(compensated.velocity_counts->both, 28);
  EXPECT_EQ(compensated.velocity_counts->one, 2);
  EXPECT_FALSE(sheared.velocity_counts);
  EXPECT_EQ(compensated.localized, 30);
  const MapFrameAlignment alignment = AlignMapToGroundTruth(*map_, false);
  const LocalizeEvaluation a = EvaluateLocalization(*dataset, compensated, alignment);
  const LocalizeEvaluation b = EvaluateLocalization(*dataset, sheared, alignment);
  ASSERT_TRUE(a.ok && b.ok);
  std::cout << "ATE " << a.ate_map_frame_m << " vs " << b.ate_map_frame_m << "\n";
  EXPECT_LT(a.ate_map_frame_m, 0.01);
  EXPECT_LT(a.ate_map_frame_m, 0.7 * b.ate_map_frame_m)
      << a.ate_map_frame_m << " against " << b.ate_map_frame_m;
}

TEST_F(LocalizationTest, AMapWithoutGroundTruthGivesNoMapFrameAndSaysWhy) {
  SavedMap map = *map_;
  for (MapKeyframe& k : map.keyframes) k.has_ground_truth = false;
  const MapFrameAlignment alignment = AlignMapToGroundTruth(map, false);
  EXPECT_FALSE(alignment.ok);
  EXPECT_NE(alignment.reason.find("ground truth"), std::string::npos) << alignment.reason;
}

}  // namespace
}  // namespace ieslam
