// The saved map of a run on the 9 real frames of tum-fr1-desk-9: what it holds, that it reads
// back bit for bit, and that each kind of bad map is refused with the file and the fault named.
#include "selection/pipeline/saved_map.h"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>

#include <unistd.h>

#include <gtest/gtest.h>
#include <zlib.h>
#include <Eigen/SparseCholesky>

#include "core/error.h"
#include "selection/pipeline/dataset_run.h"
#include "selection/pipeline/run_outputs.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

const std::string kDesk = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-fr1-desk-9";

template <typename A, typename B>
bool SameBits(const A& a, const B& b) {
  return a.size() == b.size() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(*a.data()) * a.size()) == 0);
}

void ExpectSameMap(const SavedMap& a, const SavedMap& b) {
  EXPECT_EQ(a.version, b.version);
  EXPECT_EQ(a.calibration, b.calibration);
  EXPECT_EQ(a.options, b.options);
  EXPECT_EQ(a.dataset, b.dataset);
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  for (size_t k = 0; k < a.keyframes.size(); ++k) {
    const MapKeyframe &x = a.keyframes[k], &y = b.keyframes[k];
    EXPECT_EQ(x.frame, y.frame);
    EXPECT_EQ(x.origin.dataset, y.origin.dataset);
    EXPECT_EQ(x.origin.source_index, y.origin.source_index);
    EXPECT_EQ(x.origin.timestamp, y.origin.timestamp);
    EXPECT_EQ(x.timestamp, y.timestamp);
    EXPECT_TRUE(SameBits(x.pose, y.pose) && SameBits(x.covariance, y.covariance));
    EXPECT_EQ(x.refined, y.refined);
    EXPECT_TRUE(SameBits(x.refined_pose, y.refined_pose));
    EXPECT_EQ(x.has_ground_truth, y.has_ground_truth);
    EXPECT_TRUE(SameBits(x.ground_truth, y.ground_truth));
    ASSERT_EQ(x.observations.size(), y.observations.size());
    for (size_t i = 0; i < x.observations.size(); ++i) {
      EXPECT_EQ(x.observations[i].feature_id, y.observations[i].feature_id);
      EXPECT_TRUE(SameBits(x.observations[i].z, y.observations[i].z) &&
                  SameBits(x.observations[i].Q, y.observations[i].Q));
    }
  }
  ASSERT_EQ(a.features.size(), b.features.size());
  for (size_t k = 0; k < a.features.size(); ++k) {
    EXPECT_EQ(a.features[k].id, b.features[k].id);
    EXPECT_TRUE(SameBits(a.features[k].p_w, b.features[k].p_w));
    EXPECT_TRUE(SameBits(a.features[k].covariance, b.features[k].covariance));
  }
  ASSERT_EQ(a.base_frames.size(), b.base_frames.size());
  for (size_t k = 0; k < a.base_frames.size(); ++k) {
    const MapBaseFrame &x = a.base_frames[k], &y = b.base_frames[k];
    EXPECT_EQ(x.frame, y.frame);
    EXPECT_EQ(x.timestamp, y.timestamp);
    ASSERT_EQ(x.features.size(), y.features.size());
    EXPECT_EQ(x.feature_ids, y.feature_ids);
    EXPECT_EQ(x.features.scales, y.features.scales);
    for (int i = 0; i < x.features.size(); ++i) {
      EXPECT_TRUE(SameBits(x.features.pixels[i], y.features.pixels[i]));
      EXPECT_EQ(x.features.colours[i], y.features.colours[i]);
      EXPECT_EQ(x.points[i].valid, y.points[i].valid);
      EXPECT_TRUE(SameBits(x.points[i].p_c, y.points[i].p_c) &&
                  SameBits(x.points[i].z, y.points[i].z) &&
                  SameBits(x.points[i].Q, y.points[i].Q) &&
                  SameBits(x.points[i].p_c_covariance, y.points[i].p_c_covariance));
    }
    EXPECT_EQ(cv::norm(x.features.descriptors, y.features.descriptors, cv::NORM_L1), 0.0);
  }
  const MapFilterState &f = a.filter, &g = b.filter;
  EXPECT_EQ(f.dim, g.dim);
  EXPECT_EQ(f.column_starts, g.column_starts);
  EXPECT_EQ(f.rows, g.rows);
  EXPECT_TRUE(SameBits(f.values, g.values));
  EXPECT_TRUE(SameBits(f.information_vector, g.information_vector));
  EXPECT_TRUE(SameBits(f.state, g.state));
  EXPECT_EQ(f.pose_offsets, g.pose_offsets);
  EXPECT_EQ(f.feature_offsets, g.feature_offsets);
  ASSERT_EQ(f.pending.size(), g.pending.size());
  for (size_t k = 0; k < f.pending.size(); ++k) {
    EXPECT_EQ(f.pending[k].id, g.pending[k].id);
    ASSERT_EQ(f.pending[k].sightings.size(), g.pending[k].sightings.size());
    for (size_t i = 0; i < f.pending[k].sightings.size(); ++i) {
      const FeatureSighting &x = f.pending[k].sightings[i], &y = g.pending[k].sightings[i];
      EXPECT_EQ(x.frame_id, y.frame_id);
      EXPECT_EQ(x.observation.feature_id, y.observation.feature_id);
      EXPECT_TRUE(SameBits(x.observation.z, y.observation.z) &&
                  SameBits(x.observation.Q, y.observation.Q));
    }
  }
}

class SavedMapTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("ieslam_saved_map_test_" + std::to_string(::getpid()));
    fs::create_directories(root_ / "run");
    RunOptions options;
    options.dataset = kDesk;
    options.threads = 1;
    options.pipeline.refine = true;
    dataset_ = OpenDataset(options.dataset, options.dataset_options).release();
    run_ = new RunResult(RunOnDataset(*dataset_, options));
    WriteRunOutputs((root_ / "run").string(), *dataset_, options, *run_);
  }
  static void TearDownTestSuite() {
    fs::remove_all(root_);
    delete run_;
    delete dataset_;
  }
  void SetUp() override { ASSERT_TRUE(run_->saved_map.has_value()); }

  static fs::path MapDir() { return root_ / "run" / kMapDirectory; }
  static std::string MapBytes() {
    std::ifstream in(MapDir() / kMapFileName, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  // The DataError's message of reading `bytes` as a map (empty when it reads).
  static std::string ErrorReading(const std::string& bytes) {
    const fs::path dir = root_ / "bad";
    fs::create_directories(dir);
    std::ofstream(dir / kMapFileName, std::ios::binary | std::ios::trunc) << bytes;
    try {
      ReadSavedMap(dir.string());
    } catch (const DataError& e) {
      return e.what();
    }
    return "";
  }

  static fs::path root_;
  static Dataset* dataset_;
  static RunResult* run_;
};
fs::path SavedMapTest::root_;
Dataset* SavedMapTest::dataset_ = nullptr;
RunResult* SavedMapTest::run_ = nullptr;

TEST_F(SavedMapTest, HoldsTheFiltersEstimateTheRefinedPosesAndTheGroundTruth) {
  const SavedMap& map = *run_->saved_map;
  const InformationFilter& filter = *run_->pipeline.filter;
  ASSERT_EQ(static_cast<int>(map.keyframes.size()), filter.num_poses());
  ASSERT_GE(map.keyframes.size(), 2u);
  ASSERT_TRUE(run_->refined());
  const BundleAdjustmentResult& refined = run_->pipeline.refinement->refined();
  for (const MapKeyframe& k : map.keyframes) {
    EXPECT_EQ(k.pose, filter.pose(k.frame));
    // The run released the filter's factor after the saved map; built anew, it agrees to
    // rounding.
    EXPECT_LT((k.covariance - filter.PoseCovariance(k.frame)).norm(), 1e-9 * k.covariance.norm());
    EXPECT_TRUE(k.refined);
    EXPECT_EQ(k.refined_pose, refined.poses.at(k.frame));
    EXPECT_EQ(k.origin.source_index, dataset_->info(k.frame).source_index);
    EXPECT_EQ(k.origin.timestamp, dataset_->info(k.frame).timestamp);
    EXPECT_TRUE(std::filesystem::path(k.origin.dataset).is_absolute()) << k.origin.dataset;
    const auto& gt = dataset_->info(k.frame).T_w_c_gt;
    ASSERT_TRUE(gt.has_value());
    EXPECT_TRUE(k.has_ground_truth);
    EXPECT_EQ(k.ground_truth, IsometryToPose(*gt));
    // The observations the keyframe entered with: those of the filter's problem.
    const auto& entered = run_->pipeline.selection.observations.at(k.frame);
    ASSERT_EQ(k.observations.size(), entered.size());
    for (size_t i = 0; i < entered.size(); ++i) {
      EXPECT_EQ(k.observations[i].feature_id, entered[i].feature_id);
      EXPECT_EQ(k.observations[i].z, entered[i].z);
    }
  }
  ASSERT_EQ(static_cast<int>(map.features.size()), filter.num_features());
  for (const MapFeature& f : map.features) {
    EXPECT_EQ(f.p_w, filter.feature(f.id));
    // The batched recovery gives each feature's own marginal.
    const Eigen::Matrix3d own = filter.MarginalCovariance({VariableRef::Feature(f.id)});
    EXPECT_LT((f.covariance - own).norm(), 1e-9 * own.norm()) << f.id;
  }
  // Every base frame's map features are observed by that keyframe in the filter's problem.
  int with_feature = 0;
  for (const MapBaseFrame& b : map.base_frames) {
    EXPECT_EQ(b.features.descriptors.rows, b.features.size());
    for (int64_t id : b.feature_ids) with_feature += id >= 0;
  }
  EXPECT_GE(with_feature, static_cast<int>(map.features.size()));
  // The saved matrix and vector solve to the saved state: mapping can resume from them.
  const MapFilterState& s = map.filter;
  Eigen::SparseMatrix<double> upper(s.dim, s.dim);
  std::vector<Eigen::Triplet<double>> entries;
  for (int c = 0; c < s.dim; ++c) {
    for (int k = s.column_starts[c]; k < s.column_starts[c + 1]; ++k) {
      entries.emplace_back(s.rows[k], c, s.values[k]);
    }
  }
  upper.setFromTriplets(entries.begin(), entries.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Upper> ldlt(upper);
  ASSERT_EQ(ldlt.info(), Eigen::Success);
  const Eigen::VectorXd x = ldlt.solve(s.information_vector);
  EXPECT_LT((x - s.state).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(SavedMapTest, ReadsBackBitForBit) {
  EXPECT_TRUE(fs::is_regular_file(MapDir() / kMapFileName));
  ExpectSameMap(ReadSavedMap(MapDir().string()), *run_->saved_map);
}

// Save -> load -> a filter taken over from the map: the run's estimate, to the bit, and its
// covariances.
TEST_F(SavedMapTest, AFilterRestoredFromTheReadMapHoldsTheRunsEstimate) {
  const SavedMap map = ReadSavedMap(MapDir().string());
  const InformationFilter& filter = *run_->pipeline.filter;
  InformationFilter restored(filter.options(), filter.camera());
  restored.Restore(map.filter);
  EXPECT_EQ(restored.frame_ids(), filter.frame_ids());
  EXPECT_EQ(restored.feature_ids(), filter.feature_ids());
  EXPECT_TRUE(restored.state() == filter.state());
  for (int frame : filter.frame_ids()) {
    EXPECT_EQ(restored.pose(frame), filter.pose(frame));
    const Matrix6d a = filter.PoseCovariance(frame);
    EXPECT_LT((restored.PoseCovariance(frame) - a).norm(), 1e-9 * a.norm()) << "frame " << frame;
  }
  EXPECT_NEAR(restored.LogDetInformation(), filter.LogDetInformation(),
              1e-10 * std::abs(filter.LogDetInformation()));
}

TEST_F(SavedMapTest, EachKindOfBadMapIsRefusedNamingTheFileAndTheFault) {
  const std::string good = MapBytes();
  ASSERT_EQ(ErrorReading(good), "");
  const std::string file = (root_ / "bad" / kMapFileName).string();

  EXPECT_NE(ErrorReading(good.substr(0, good.size() / 2)).find(file + ": truncated"),
            std::string::npos);
  // Another format version, under a header whose checksum is right.
  std::string version = good;
  version[8] = static_cast<char>(kMapFormatVersion + 1);
  const uint32_t crc = static_cast<uint32_t>(
      crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(version.data()), 16));
  std::memcpy(&version[16], &crc, 4);
  EXPECT_NE(
      ErrorReading(version).find("format version " + std::to_string(kMapFormatVersion + 1) +
                                 ", this build reads version " + std::to_string(kMapFormatVersion)),
      std::string::npos)
      << ErrorReading(version);
  version[9] ^= 0x01;  // under the header's checksum
  EXPECT_NE(ErrorReading(version).find("header's checksum"), std::string::npos);
  std::string flipped = good;
  flipped[good.size() - 100] ^= 0x01;  // in the last section
  EXPECT_NE(ErrorReading(flipped).find("checksum of section 'FILT'"), std::string::npos)
      << ErrorReading(flipped);
  EXPECT_NE(ErrorReading("IESLAMAX" + good.substr(8)).find("not an ieslam map"), std::string::npos);
  fs::remove(root_ / "bad" / kMapFileName);
  EXPECT_NE(ErrorReading("").find("truncated"), std::string::npos);

  SavedMap map = *run_->saved_map;
  // Contents that do not hold together.
  map.base_frames[0].feature_ids[0] = 1LL << 40;
  const fs::path dir = root_ / "inconsistent";
  fs::create_directories(dir);
  WriteSavedMap(dir.string(), map);
  try {
    ReadSavedMap(dir.string());
    FAIL() << "an unknown feature id was read";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("which the map does not hold"), std::string::npos)
        << e.what();
  }
  map = *run_->saved_map;
  ASSERT_FALSE(map.keyframes[1].observations.empty());
  map.keyframes[1].observations[0].feature_id = 1LL << 41;
  WriteSavedMap(dir.string(), map);
  try {
    ReadSavedMap(dir.string());
    FAIL() << "an observation of an unknown feature was read";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("observes feature"), std::string::npos) << e.what();
  }
  map = *run_->saved_map;
  map.features[0].id = -5;
  map.filter.feature_offsets[0].first = -5;
  WriteSavedMap(dir.string(), map);
  try {
    ReadSavedMap(dir.string());
    FAIL() << "a negative feature id was read";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("feature -5 has a negative id"), std::string::npos)
        << e.what();
  }
  // Another calibration.
  Rig other = dataset_->rig();
  other.colour.fx += 1.0;
  EXPECT_NO_THROW(CheckMapCalibration(*run_->saved_map, dataset_->rig(), MapDir().string()));
  EXPECT_THROW(CheckMapCalibration(*run_->saved_map, other, MapDir().string()), DataError);
}

// With delayed initialisation the map keeps the pending features: their sightings in the
// filter's section (read back bit for bit, and taken over by a restored filter), their ids in
// the base frames and in the keyframes' observations, so that a later session seeing them
// again brings them in. A sighting from a frame that is no keyframe is refused.
TEST(SavedMapDelayedTest, KeepsThePendingFeatures) {
  const fs::path root =
      fs::temp_directory_path() / ("ieslam_saved_map_delayed_test_" + std::to_string(::getpid()));
  fs::create_directories(root / "run");
  RunOptions options;
  options.dataset = kDesk;
  options.threads = 1;
  options.pipeline.filter.min_sightings = 2;
  const std::unique_ptr<Dataset> dataset = OpenDataset(options.dataset, options.dataset_options);
  const RunResult run = RunOnDataset(*dataset, options);
  WriteRunOutputs((root / "run").string(), *dataset, options, run);
  ASSERT_TRUE(run.saved_map.has_value());
  const SavedMap& map = *run.saved_map;
  const InformationFilter& filter = *run.pipeline.filter;
  ASSERT_GT(filter.num_pending_features(), 0);
  ASSERT_EQ(static_cast<int>(map.filter.pending.size()), filter.num_pending_features());
  int pending_rows = 0;
  for (const MapBaseFrame& b : map.base_frames) {
    for (int64_t id : b.feature_ids) pending_rows += id >= 0 && filter.IsPending(id) ? 1 : 0;
  }
  EXPECT_GE(pending_rows, filter.num_pending_features());

  const SavedMap read = ReadSavedMap((root / "run" / kMapDirectory).string());
  ExpectSameMap(read, map);
  InformationFilter restored(filter.options(), filter.camera());
  restored.Restore(read.filter);
  EXPECT_EQ(restored.num_pending_features(), filter.num_pending_features());
  EXPECT_TRUE(restored.state() == filter.state());

  SavedMap bad = map;
  bad.filter.pending.front().sightings.front().frame_id = 1 << 20;
  WriteSavedMap((root / "run" / kMapDirectory).string(), bad);
  try {
    ReadSavedMap((root / "run" / kMapDirectory).string());
    FAIL() << "a sighting from no keyframe was read";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("which is no keyframe"), std::string::npos) << e.what();
  }
  fs::remove_all(root);
}

}  // namespace
}  // namespace ieslam
