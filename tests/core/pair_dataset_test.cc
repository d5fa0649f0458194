#include "core/pair_dataset.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/calibration.h"
#include "core/dataset_test_files.h"
#include "core/error.h"

namespace ieslam {
namespace {

TEST_F(DatasetFilesTest, PairDatasetReadsTwoCamerasAtTheirOwnSizes) {
  Rig rig = ReadCalibration(DefaultCalibrationPath("sr3000_dragonfly2"));
  rig.name = "small_pair";
  // The 1024x768 camera scaled down 16 times: calibrations must keep the principal point
  // inside the image.
  rig.colour.width = 64;
  rig.colour.height = 48;
  rig.colour.fx /= 16.0;
  rig.colour.fy /= 16.0;
  rig.colour.cx = 31.5;
  rig.colour.cy = 23.5;
  WriteCalibration(Path("calib.yaml"), rig);
  WriteImage("c/0.png", Colour(64, 48));
  WriteImage("c/1.png", Colour(64, 48));
  WriteImage("r/0.png", Depth(176, 144, 2500));
  WriteImage("r/1.png", Depth(176, 144, 0));
  WriteText("colour.txt", "# colour\n10.000 c/0.png\n10.100 c/1.png\n");
  WriteText("range.txt", "10.000 r/0.png\n10.100 r/1.png\n");
  WriteText("groundtruth.txt", "10.0 0 0 0 0 0 0 1\n10.1 0.2 0 0 0 0 0 1\n");
  EXPECT_EQ(DetectDatasetFormat(dir_), "pair");
  const auto dataset = OpenDataset(dir_, DatasetOptions());
  EXPECT_EQ(dataset->format(), "pair");
  ASSERT_EQ(dataset->size(), 2);
  EXPECT_EQ(dataset->rig().name, "small_pair");
  EXPECT_EQ(dataset->calibration_path(), Path("calib.yaml"));
  EXPECT_EQ(dataset->info(1).depth_path, Path("r/1.png"));
  ASSERT_TRUE(dataset->info(1).T_w_c_gt.has_value());
  EXPECT_NEAR(dataset->info(1).T_w_c_gt->translation().x(), 0.2, 1e-12);
  const Frame f0 = dataset->Load(0);
  EXPECT_EQ(f0.colour.size(), cv::Size(64, 48));
  EXPECT_EQ(f0.depth.size(), cv::Size(176, 144));
  EXPECT_NEAR(f0.depth.at<float>(72, 88), 2.5f, 1e-6);
  EXPECT_EQ(dataset->Load(1).depth.at<float>(0, 0), 0.0f);  // raw 0: no measurement

  std::filesystem::remove(Path("calib.yaml"));
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, Path("calib.yaml"));
}

TEST_F(DatasetFilesTest, PairConstructorRejectsBadOptionsWithConfigError) {
  DatasetOptions bad;
  bad.max_ground_truth_diff_s = -1.0;
  ExpectConfigError([&] { PairDataset(dir_, bad); }, "max_ground_truth_diff_s");
}

}  // namespace
}  // namespace ieslam
