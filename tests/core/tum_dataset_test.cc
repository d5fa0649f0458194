#include "core/tum_dataset.h"

#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/calibration.h"
#include "core/dataset_test_files.h"
#include "core/error.h"
#include "core/trajectory.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- real data: TUM

TEST(TumDataset, AssociatesTheNinePairs) {
  const auto dataset = OpenDataset(kTum, DatasetOptions());
  EXPECT_EQ(dataset->format(), "tum");
  ASSERT_EQ(dataset->size(), 9);
  EXPECT_EQ(dataset->total_frames(), 9);
  EXPECT_EQ(dataset->calibration_path(), DefaultCalibrationPath("tum_fr1"));
  EXPECT_TRUE(Contains(dataset->calibration_source(), "freiburg1"));
  EXPECT_EQ(dataset->rig().name, "tum_fr1");
  EXPECT_EQ(dataset->info(0).colour_path, kTum + "/rgb/1305031453.359684.png");
  EXPECT_EQ(dataset->info(0).depth_path, kTum + "/depth/1305031453.374112.png");
  EXPECT_EQ(dataset->info(8).depth_path, kTum + "/depth/1305031453.636951.png");
  for (int i = 0; i < dataset->size(); ++i) {
    const FrameInfo& f = dataset->info(i);
    EXPECT_EQ(f.index, i);
    EXPECT_EQ(f.source_index, i);
    const double depth_t = std::stod(std::filesystem::path(f.depth_path).stem().string());
    EXPECT_LT(std::fabs(depth_t - f.timestamp), 0.02) << i;
    EXPECT_EQ(std::stod(std::filesystem::path(f.colour_path).stem().string()), f.timestamp);
  }
}

TEST(TumDataset, LoadsColourAndDepthInMetres) {
  const auto dataset = OpenDataset(kTum, DatasetOptions());
  const Frame frame = dataset->Load(4);
  EXPECT_EQ(frame.info.index, 4);
  ASSERT_EQ(frame.colour.type(), CV_8UC3);
  ASSERT_EQ(frame.depth.type(), CV_32FC1);
  EXPECT_EQ(frame.colour.size(), cv::Size(640, 480));
  const cv::Mat raw = cv::imread(dataset->info(4).depth_path, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC1);
  EXPECT_EQ(cv::countNonZero(frame.colour.reshape(1) !=
                             cv::imread(dataset->info(4).colour_path).reshape(1)),
            0);
  int valid = 0, invalid = 0;
  for (int r = 0; r < raw.rows; ++r) {
    for (int c = 0; c < raw.cols; ++c) {
      const int v = raw.at<uint16_t>(r, c);
      const float d = frame.depth.at<float>(r, c);
      if (v == 0) {
        ASSERT_EQ(d, 0.0f);
        ++invalid;
      } else if (v / 5000.0 >= 0.3 && v / 5000.0 <= 10.0) {
        ASSERT_NEAR(d, v / 5000.0, 1e-6) << r << "," << c;
        ++valid;
      }
    }
  }
  EXPECT_GT(valid, 100000);
  EXPECT_GT(invalid, 0);
}

TEST(TumDataset, GroundTruthIsInterpolatedAtEachFrame) {
  const auto dataset = OpenDataset(kTum, DatasetOptions());
  ASSERT_TRUE(dataset->has_ground_truth());
  const Trajectory gt = ReadTumTrajectory(kTum + "/groundtruth.txt");
  const Trajectory at_frames = dataset->GroundTruth();
  ASSERT_EQ(at_frames.size(), 9u);
  for (int i = 0; i < dataset->size(); ++i) {
    const FrameInfo& f = dataset->info(i);
    ASSERT_TRUE(f.T_w_c_gt.has_value()) << i;
    EXPECT_EQ(at_frames[i].timestamp, f.timestamp);
    // The two motion-capture poses around the frame, interpolated here independently.
    size_t k = 0;
    while (gt[k + 1].timestamp <= f.timestamp) ++k;
    const double a = (f.timestamp - gt[k].timestamp) / (gt[k + 1].timestamp - gt[k].timestamp);
    ASSERT_GE(a, 0.0);
    ASSERT_LT(a, 1.0);
    const Eigen::Vector3d t =
        gt[k].T_w_c.translation() + a * (gt[k + 1].T_w_c.translation() - gt[k].T_w_c.translation());
    EXPECT_LT((f.T_w_c_gt->translation() - t).norm(), 1e-9) << i;
    const double angle =
        Eigen::AngleAxisd(f.T_w_c_gt->linear().transpose() * gt[k].T_w_c.linear()).angle();
    EXPECT_LT(angle, 0.02) << i;  // within one 10 ms step of hand-held rotation
  }
}

TEST_F(DatasetFilesTest, TumMissingOrEmptyListsNameTheFile) {
  WriteText("depth.txt", "1.0 depth/1.png\n");
  ExpectDataError([&] { OpenDataset(dir_, Format("tum")); }, Path("rgb.txt"));
  WriteText("rgb.txt", "# only a comment\n\n");
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, Path("rgb.txt"));
}

TEST_F(DatasetFilesTest, TumUnsortedOrDuplicateTimestampsNameFileAndLine) {
  MakeTum(2);
  WriteText("rgb.txt", "# c\n2.0 rgb/a.png\n1.0 rgb/b.png\n");
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, Path("rgb.txt") + ":3");
  WriteText("rgb.txt", "2.0 rgb/a.png\n2.0 rgb/b.png\n");
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, Path("rgb.txt") + ":2");
  WriteText("rgb.txt", "2.0\n");
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, Path("rgb.txt") + ":1");
}

TEST_F(DatasetFilesTest, TumCalibrationChoiceIsReported) {
  MakeTum(3);
  auto dataset = OpenDataset(dir_, DatasetOptions());
  EXPECT_EQ(dataset->size(), 3);
  EXPECT_FALSE(dataset->has_ground_truth());
  EXPECT_EQ(dataset->calibration_path(), DefaultCalibrationPath("tum_fr1"));
  EXPECT_TRUE(Contains(dataset->calibration_source(), "default"));
  EXPECT_EQ(dataset->calibration_chosen_by(), "fallback");
  // The guess is a warning, naming the directory and the file used.
  ASSERT_EQ(dataset->warnings().size(), 1u);
  EXPECT_TRUE(Contains(dataset->warnings()[0], "'" + fs::path(dir_).filename().string() + "'"))
      << dataset->warnings()[0];
  EXPECT_TRUE(Contains(dataset->warnings()[0], DefaultCalibrationPath("tum_fr1")));
  EXPECT_TRUE(Contains(dataset->warnings()[0], "--calib"));
  EXPECT_NEAR(dataset->Load(2).depth.at<float>(10, 10), 1.0f, 1e-6);

  // A sequence named after freiburg2 gets fr2's intrinsics.
  const std::string fr2 = Path("rgbd_dataset_freiburg2_xyz");
  MakeTum(1, "rgbd_dataset_freiburg2_xyz");
  dataset = OpenDataset(fr2 + "/", DatasetOptions());
  EXPECT_EQ(dataset->rig().name, "tum_fr2");
  EXPECT_TRUE(Contains(dataset->calibration_source(), "freiburg2"));
  EXPECT_EQ(dataset->calibration_chosen_by(), "directory name");
  EXPECT_TRUE(dataset->warnings().empty());

  // calib_file wins over the name.
  DatasetOptions options;
  options.calib_file = DefaultCalibrationPath("tum_fr3");
  dataset = OpenDataset(fr2, options);
  EXPECT_EQ(dataset->rig().name, "tum_fr3");
  EXPECT_EQ(dataset->calibration_chosen_by(), "option");
  EXPECT_TRUE(dataset->warnings().empty());
  // As it does over a name that names no camera.
  EXPECT_TRUE(OpenDataset(dir_, options)->warnings().empty());

  // A calib.yaml inside the sequence (as `ieslam synth` writes) wins over the name too.
  Rig own = ReadCalibration(DefaultCalibrationPath("tum_fr3"));
  own.name = "own_rig";
  WriteCalibration(fr2 + "/calib.yaml", own);
  dataset = OpenDataset(fr2, DatasetOptions());
  EXPECT_EQ(dataset->rig().name, "own_rig");
  EXPECT_EQ(dataset->calibration_path(), fr2 + "/calib.yaml");
  EXPECT_EQ(dataset->calibration_chosen_by(), "dataset file");
}

// A calibration's depth correction is divided out of every range pixel as the frame loads:
// the reading over the factor at that pixel's undistorted normalised coordinates.
TEST_F(DatasetFilesTest, TumDepthCorrectionIsDividedOutPerPixel) {
  Rig rig = ReadCalibration(DefaultCalibrationPath("tum_fr1"));
  rig.range.depth_correction = {-0.03, 0.02, 0.05};
  DatasetOptions options;
  options.calib_file = Path("corrected.yaml");
  WriteCalibration(options.calib_file, rig);
  const auto plain = OpenDataset(kTum, DatasetOptions());
  const auto corrected = OpenDataset(kTum, options);
  const cv::Mat read = plain->Load(4).depth;
  const cv::Mat depth = corrected->Load(4).depth;
  int checked = 0;
  for (int r = 0; r < read.rows; r += 7) {
    for (int c = 0; c < read.cols; c += 7) {
      const float v = read.at<float>(r, c);
      if (v == 0.0f) {
        EXPECT_EQ(depth.at<float>(r, c), 0.0f);
        continue;
      }
      const Eigen::Vector3d ray = rig.range.camera.Unproject(Eigen::Vector2d(c, r));
      ASSERT_NEAR(depth.at<float>(r, c), v / rig.range.DepthCorrectionFactor(ray.x(), ray.y()),
                  2e-6)
          << r << "," << c;
      ++checked;
    }
  }
  EXPECT_GT(checked, 2000);
  // The left and the right of the image moved apart (a = -0.03): it is not a no-op.
  const Eigen::Vector3d left = rig.range.camera.Unproject(Eigen::Vector2d(20, 240));
  EXPECT_GT(rig.range.DepthCorrectionFactor(left.x(), left.y()), 1.01);
  // The same division without the dataset's cached divisors.
  const cv::Mat raw = cv::imread(corrected->info(4).depth_path, cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::countNonZero(RangeImageToMetres(raw, rig.range) != depth), 0);
}

TEST_F(DatasetFilesTest, TumConstructorRejectsBadOptionsWithConfigError) {
  MakeTum(2);
  DatasetOptions bad;
  bad.stride = 0;
  ExpectConfigError([&] { TumDataset(dir_, bad); }, "stride");
  EXPECT_EQ(TumDataset(dir_, DatasetOptions()).size(), 2);
}

}  // namespace
}  // namespace ieslam
