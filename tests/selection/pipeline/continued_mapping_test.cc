// Mapping on from a saved map, on synthetic sequences with exact ground truth: one sequence
// mapped in two halves against the same sequence in one run, and a second pass along another
// path through the same room joining the first pass's map.
#include <algorithm>
#include <filesystem>
#include <memory>
#include <set>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "core/error.h"
#include "frontend/simulation/synthetic_dataset.h"
#include "selection/pipeline/continued_dataset.h"
#include "selection/pipeline/dataset_run.h"
#include "two_passes.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

RunOptions Options(const fs::path& dir, int first = 0, int last = -1) {
  RunOptions options;
  options.dataset = dir.string();
  options.dataset_options.first = first;
  options.dataset_options.last = last;
  options.threads = 1;
  options.build_map = false;
  return options;
}

RunResult RunOn(const RunOptions& options) {
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  return RunOnDataset(*dataset, options);
}

// The saved map read back from its file, as a later session has it.
LoadedMap ReadBack(const SavedMap& map, const fs::path& dir) {
  fs::create_directories(dir);
  WriteSavedMap(dir.string(), map);
  return LoadMap(dir.string());
}

// The dataset of `options` after the map `map`.
struct Continued {
  Continued(const LoadedMap& map, const RunOptions& options)
      : rest(OpenDataset(options.dataset, options.dataset_options)),
        dataset(map, *rest, options.dataset_options) {}
  std::unique_ptr<Dataset> rest;
  ContinuedDataset dataset;
};

class ContinuedMappingTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("ieslam_continued_test_" + std::to_string(::getpid()));
    WriteSyntheticDataset((root_ / "first").string(), FirstPass());
    // Numbered from the first pass's start time: the map's timestamps are shifted past.
    WriteSyntheticDataset((root_ / "second").string(), SecondPass());
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  static fs::path root_;
};
fs::path ContinuedMappingTest::root_;

TEST_F(ContinuedMappingTest, TwoHalvesGiveTheMapOfOneRunWithTheMapsKeyframesFirst) {
  const RunResult whole = RunOn(Options(root_ / "first"));
  const RunResult half = RunOn(Options(root_ / "first", 0, 19));
  ASSERT_TRUE(half.saved_map.has_value());
  const LoadedMap map = ReadBack(*half.saved_map, root_ / "half_map");
  const RunOptions options = Options(root_ / "first", 20);
  const Continued continued(map, options);
  const int m = continued.dataset.map_frames();
  ASSERT_EQ(m, static_cast<int>(map.map.keyframes.size()));
  ASSERT_EQ(continued.dataset.size(), m + 20);
  EXPECT_EQ(continued.dataset.timestamp_shift_s(), 0.0);  // the rest follows the map in time
  for (int k = 0; k < m; ++k) {
    EXPECT_EQ(continued.dataset.info(k).source_index, half.pipeline.selection.selected[k]);
  }
  EXPECT_EQ(continued.dataset.info(m).source_index, 20);
  // The mapping run's dataset is where the map says: the map's frames have its images.
  ASSERT_EQ(continued.dataset.map_frames_without_images(), 0)
      << continued.dataset.map_images_missing();
  const auto all_frames = OpenDataset((root_ / "first").string(), DatasetOptions());
  for (int k = 0; k < m; ++k) {
    const int frame = half.pipeline.selection.selected[k];
    EXPECT_EQ(continued.dataset.info(k).colour_path, all_frames->info(frame).colour_path);
    EXPECT_EQ(continued.dataset.info(k).depth_path, all_frames->info(frame).depth_path);
  }
  const RunResult run = ContinueMapping(continued.dataset, options);

  // The map's keyframes come first, with the observations they entered with; new ones follow.
  const std::vector<int>& selected = run.pipeline.selection.selected;
  ASSERT_GT(static_cast<int>(selected.size()), m);
  for (int k = 0; k < m; ++k) {
    ASSERT_EQ(selected[k], k);
    EXPECT_EQ(run.pipeline.selection.observations.at(k).size(),
              map.map.keyframes[k].observations.size());
  }
  EXPECT_EQ(run.map_frames, m);
  EXPECT_EQ(run.continued_map_file, map.file());
  EXPECT_EQ(run.frames_processed(), m + 20);
  EXPECT_TRUE(run.frames_skipped.empty());
  // The map's features (in its state, or pending: seen by one keyframe) are observed again,
  // and new ones get ids above them.
  int64_t last_map_id = -1;
  std::set<int64_t> map_ids;
  for (const MapFeature& f : map.map.features) {
    map_ids.insert(f.id);
    last_map_id = std::max(last_map_id, f.id);
  }
  for (const PendingFeature& p : map.map.filter.pending) {
    map_ids.insert(p.id);
    last_map_id = std::max(last_map_id, p.id);
  }
  int reobserved = 0;
  for (size_t k = m; k < selected.size(); ++k) {
    for (const FeatureObservation& o : run.pipeline.selection.observations.at(selected[k])) {
      reobserved += map_ids.count(o.feature_id) > 0 ? 1 : 0;
    }
  }
  EXPECT_GT(reobserved, 50);
  EXPECT_GT(run.pipeline.filter->num_features(), static_cast<int>(map.map.features.size()));
  for (const int64_t id : run.pipeline.filter->feature_ids()) {
    if (map_ids.count(id) == 0) {
      EXPECT_GT(id, last_map_id);
    }
  }

  // One map of the whole sequence, as good as one run over it (the split may change the
  // decisions near it, so the selections need not be equal).
  ASSERT_GE(whole.ate_keyframes_m, 0.0);
  ASSERT_GE(run.ate_keyframes_m, 0.0);
  EXPECT_EQ(run.keyframes.size(), selected.size());
  EXPECT_LT(run.ate_keyframes_m, 0.01);
  EXPECT_LT(run.ate_keyframes_m, 1.5 * whole.ate_keyframes_m + 0.001)
      << "one run: " << whole.ate_keyframes_m;
  ASSERT_TRUE(run.saved_map.has_value());
  EXPECT_EQ(run.saved_map->keyframes.size(), selected.size());
  for (const MapKeyframe& k : run.saved_map->keyframes) EXPECT_TRUE(k.has_ground_truth);
}

// With delayed initialisation the map's pending features survive the map file: the next
// session's frames that see them again bring them into the state, with the sightings the map
// kept, and the split run is as good as one run over the sequence.
TEST_F(ContinuedMappingTest, TheMapsPendingFeaturesEnterWhenTheNextSessionSeesThem) {
  RunOptions whole_options = Options(root_ / "first"),
             half_options = Options(root_ / "first", 0, 19);
  RunOptions options = Options(root_ / "first", 20);
  for (RunOptions* o : {&whole_options, &half_options, &options}) {
    o->pipeline.filter.min_sightings = 2;
  }
  const RunResult whole = RunOn(whole_options);
  const RunResult half = RunOn(half_options);
  ASSERT_TRUE(half.saved_map.has_value());
  const LoadedMap map = ReadBack(*half.saved_map, root_ / "pending_map");
  ASSERT_FALSE(map.map.filter.pending.empty());
  const RunResult run = ContinueMapping(Continued(map, options).dataset, options);
  int entered = 0;
  for (const PendingFeature& p : map.map.filter.pending) {
    entered += run.pipeline.filter->HasFeature(p.id) ? 1 : 0;
  }
  EXPECT_GT(entered, 10);
  ASSERT_GE(whole.ate_keyframes_m, 0.0);
  ASSERT_GE(run.ate_keyframes_m, 0.0);
  EXPECT_LT(run.ate_keyframes_m, 0.01);
  EXPECT_LT(run.ate_keyframes_m, 1.5 * whole.ate_keyframes_m + 0.001)
      << "one run: " << whole.ate_keyframes_m;
}

TEST_F(ContinuedMappingTest, AContinuedMapReadsBackAndGoesOnAgain) {
  const RunResult third = RunOn(Options(root_ / "first", 0, 13));
  ASSERT_TRUE(third.saved_map.has_value());
  const RunOptions middle = Options(root_ / "first", 14, 26);
  const LoadedMap first_map = ReadBack(*third.saved_map, root_ / "third_map");
  const RunResult two = ContinueMapping(Continued(first_map, middle).dataset, middle);
  ASSERT_TRUE(two.saved_map.has_value());
  // Renumbered, the continued run's map holds together as any run's (ReadSavedMap checks it),
  // and its keyframes keep their frames' indices in the dataset.
  const LoadedMap second_map = ReadBack(*two.saved_map, root_ / "two_thirds_map");
  ASSERT_EQ(second_map.map.keyframes.size(), two.pipeline.selection.selected.size());
  for (size_t k = 0; k < second_map.map.keyframes.size(); ++k) {
    const int frame = two.pipeline.selection.selected[k];
    const int in_dataset = frame < two.map_frames ? third.pipeline.selection.selected[frame]
                                                  : 14 + frame - two.map_frames;
    const FrameOrigin& origin = second_map.map.keyframes[k].origin;
    EXPECT_EQ(origin.source_index, in_dataset) << "keyframe " << k;
    EXPECT_EQ(origin.dataset, (root_ / "first").lexically_normal().string());
  }
  const RunOptions last = Options(root_ / "first", 27);
  const RunResult all = ContinueMapping(Continued(second_map, last).dataset, last);
  EXPECT_EQ(all.map_frames, static_cast<int>(second_map.map.keyframes.size()));
  EXPECT_TRUE(all.frames_skipped.empty());
  EXPECT_GT(all.pipeline.selection.selected.size(), second_map.map.keyframes.size());
  ASSERT_GE(all.ate_keyframes_m, 0.0);
  EXPECT_LT(all.ate_keyframes_m, 0.01);
}

TEST_F(ContinuedMappingTest, IntervalFramesAreCountedFromTheDatasetsFirstFrame) {
  const RunResult half = RunOn(Options(root_ / "first", 0, 19));
  ASSERT_TRUE(half.saved_map.has_value());
  const LoadedMap map = ReadBack(*half.saved_map, root_ / "interval_map");
  RunOptions options = Options(root_ / "first", 20);
  options.pipeline.selector.kind = SelectorKind::kInterval;
  options.pipeline.selector.interval = 3;
  const RunResult run = ContinueMapping(Continued(map, options).dataset, options);
  const std::vector<int>& selected = run.pipeline.selection.selected;
  ASSERT_EQ(static_cast<int>(selected.size()), run.map_frames + 7);  // 20, 23, .., 38
  for (size_t k = run.map_frames; k < selected.size(); ++k) {
    EXPECT_EQ((selected[k] - run.map_frames) % 3, 0) << "frame " << selected[k];
  }
}

TEST_F(ContinuedMappingTest, ASecondPassThroughTheRoomJoinsTheFirstPassesMap) {
  const RunResult first = RunOn(Options(root_ / "first"));
  ASSERT_TRUE(first.saved_map.has_value());
  const LoadedMap map = ReadBack(*first.saved_map, root_ / "first_map");
  const RunOptions options = Options(root_ / "second");
  const Continued second(map, options);
  const ContinuedDataset& continued = second.dataset;
  // Numbered from the same start, the second pass is moved to follow the map, with a warning.
  EXPECT_GT(continued.timestamp_shift_s(), 0.0);
  EXPECT_GT(continued.info(continued.map_frames()).timestamp,
            continued.info(continued.map_frames() - 1).timestamp);
  ASSERT_FALSE(continued.warnings().empty());
  EXPECT_NE(continued.warnings().back().find("shifted"), std::string::npos);
  const RunResult run = ContinueMapping(continued, options);
  EXPECT_TRUE(run.frames_skipped.empty());
  // The second pass is placed in the first pass's frame: the ground truth of both is one
  // frame, and the keyframe ATE over both passes is that of one map.
  ASSERT_GE(run.ate_keyframes_m, 0.0);
  EXPECT_LT(run.ate_keyframes_m, 0.01);
  EXPECT_GT(run.pipeline.selection.selected.size(), map.map.keyframes.size());
  // The joined map remembers where each keyframe came from, before the shift, so that both
  // passes' images are found again.
  ASSERT_TRUE(run.saved_map.has_value());
  const LoadedMap joined = ReadBack(*run.saved_map, root_ / "joined_map");
  const int m = static_cast<int>(map.map.keyframes.size());
  for (size_t k = 0; k < joined.map.keyframes.size(); ++k) {
    const FrameOrigin& o = joined.map.keyframes[k].origin;
    const fs::path from = root_ / (static_cast<int>(k) < m ? "first" : "second");
    EXPECT_EQ(o.dataset, from.lexically_normal().string()) << "keyframe " << k;
    if (static_cast<int>(k) >= m) {
      EXPECT_NEAR(o.timestamp + continued.timestamp_shift_s(), joined.map.keyframes[k].timestamp,
                  1e-9);
    }
  }
  const RunOptions again = Options(root_ / "first", 0, 4);
  const Continued third(joined, again);
  EXPECT_EQ(third.dataset.map_frames_without_images(), 0) << third.dataset.map_images_missing();
  const std::string second_image = third.dataset.info(m).colour_path;
  EXPECT_NE(second_image.find("second"), std::string::npos) << second_image;

  // The map's keyframes move only by what the second pass tells about them.
  for (size_t k = 0; k < map.map.keyframes.size(); ++k) {
    const Eigen::Vector3d before = map.map.keyframes[k].pose.head<3>();
    const Eigen::Vector3d after = run.pipeline.filter->pose(static_cast<int>(k)).head<3>();
    EXPECT_LT((after - before).norm(), 0.005) << "keyframe " << k;
  }
}

TEST_F(ContinuedMappingTest, WithoutTheMappingDatasetTheMapsFramesAreLeftOutOfTheDenseMap) {
  const RunResult half = RunOn(Options(root_ / "first", 0, 19));
  ASSERT_TRUE(half.saved_map.has_value());
  RunOptions options = Options(root_ / "first", 20);
  options.build_map = true;
  const LoadedMap map = ReadBack(*half.saved_map, root_ / "images_map");
  const int m = static_cast<int>(map.map.keyframes.size());
  ASSERT_GE(m, 2);
  const std::string gone = (root_ / "moved_away").string();
  LoadedMap moved = map, one_moved = map, shifted = map;
  for (MapKeyframe& k : moved.map.keyframes) k.origin.dataset = gone;
  one_moved.map.keyframes[1].origin.dataset = gone;
  shifted.map.keyframes[0].origin.timestamp += 0.5;  // the dataset has no frame there
  const Continued with(map, options), without(moved, options), one(one_moved, options),
      elsewhere(shifted, options);
  EXPECT_EQ(with.dataset.map_frames_without_images(), 0);
  EXPECT_EQ(without.dataset.map_frames_without_images(), m);
  EXPECT_EQ(one.dataset.map_frames_without_images(), 1);
  EXPECT_FALSE(one.dataset.has_images(1));
  EXPECT_TRUE(one.dataset.has_images(0));
  EXPECT_EQ(elsewhere.dataset.map_frames_without_images(), 1);
  EXPECT_FALSE(elsewhere.dataset.has_images(0));
  EXPECT_NE(without.dataset.map_images_missing().find(gone), std::string::npos)
      << without.dataset.map_images_missing();
  EXPECT_NE(elsewhere.dataset.map_images_missing().find("1 of its"), std::string::npos)
      << elsewhere.dataset.map_images_missing();
  const RunResult full = ContinueMapping(with.dataset, options);
  const RunResult part = ContinueMapping(one.dataset, options);
  const RunResult none = ContinueMapping(without.dataset, options);
  // The same estimate; the map's frames are in the dense map only when their images are.
  EXPECT_EQ(full.keyframes.size(), none.keyframes.size());
  ASSERT_TRUE(full.map.has_value() && part.map.has_value() && none.map.has_value());
  EXPECT_GT(full.map->size(), part.map->size());
  EXPECT_GT(part.map->size(), none.map->size());
  const auto left_out = [](const RunResult& r) {
    std::string found;
    for (const std::string& w : r.warnings) {
      if (w.find("keyframes are left out of the map") != std::string::npos) found += w;
    }
    return found;
  };
  EXPECT_EQ(left_out(full), "");
  EXPECT_EQ(left_out(part).rfind("1 of the saved map's", 0), 0u) << left_out(part);
  EXPECT_EQ(left_out(none).rfind(std::to_string(m) + " of the saved map's", 0), 0u)
      << left_out(none);
}

TEST_F(ContinuedMappingTest, ARelativeDatasetPathIsSavedAsAnAbsoluteOne) {
  const fs::path before = fs::current_path();
  fs::current_path(root_);
  const RunResult run = RunOn(Options("first", 0, 9));
  fs::current_path(before);
  ASSERT_TRUE(run.saved_map.has_value());
  for (const MapKeyframe& k : run.saved_map->keyframes) {
    EXPECT_EQ(k.origin.dataset, (root_ / "first").lexically_normal().string());
  }
  // From elsewhere, the map's frames still have their images.
  const LoadedMap map = ReadBack(*run.saved_map, root_ / "relative_map");
  EXPECT_EQ(Continued(map, Options(root_ / "first", 10)).dataset.map_frames_without_images(), 0);
}

TEST_F(ContinuedMappingTest, DeadReckoningHasNoFilterToGoOnWith) {
  const RunResult half = RunOn(Options(root_ / "first", 0, 9));
  ASSERT_TRUE(half.saved_map.has_value());
  const LoadedMap map = ReadBack(*half.saved_map, root_ / "dead_map");
  RunOptions options = Options(root_ / "first", 10, 19);
  options.pipeline.selector.kind = SelectorKind::kDeadReckoning;
  EXPECT_THROW(ContinueMapping(Continued(map, options).dataset, options), ConfigError);
}

TEST_F(ContinuedMappingTest, AMapOfAnotherCalibrationOrOutOfTimeOrderIsRefused) {
  const RunResult half = RunOn(Options(root_ / "first", 0, 9));
  ASSERT_TRUE(half.saved_map.has_value());
  const RunOptions options = Options(root_ / "first", 10, 19);
  LoadedMap other = ReadBack(*half.saved_map, root_ / "other_map");
  other.map.calibration += "# another camera\n";
  try {
    const Continued continued(other, options);
    ADD_FAILURE() << "another calibration taken";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find(other.file()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("another calibration"), std::string::npos) << e.what();
  }
  LoadedMap shuffled = ReadBack(*half.saved_map, root_ / "shuffled_map");
  ASSERT_GE(shuffled.map.keyframes.size(), 2u);
  std::swap(shuffled.map.keyframes[0].timestamp, shuffled.map.keyframes[1].timestamp);
  EXPECT_THROW(Continued(shuffled, options), DataError);
}

}  // namespace
}  // namespace ieslam
