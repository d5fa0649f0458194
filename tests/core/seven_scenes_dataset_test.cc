#include "core/seven_scenes_dataset.h"

#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/dataset_test_files.h"
#include "core/error.h"

namespace ieslam {
namespace {

TEST(SevenScenesDataset, ConstructorRejectsBadOptionsWithConfigError) {
  DatasetOptions bad;
  bad.first = 5;
  bad.last = 4;
  ExpectConfigError([&] { SevenScenesDataset(kSevenScenes, bad); }, "last");
}

// ---------------------------------------------------------------- real data: 7-Scenes

TEST(SevenScenesDataset, OpensFiveHundredFramesWithPoses) {
  const auto dataset = OpenDataset(kSevenScenes, DatasetOptions());
  EXPECT_EQ(dataset->format(), "7scenes");
  ASSERT_EQ(dataset->size(), 500);
  EXPECT_DOUBLE_EQ(dataset->info(30).timestamp, 1.0);
  EXPECT_EQ(dataset->info(7).colour_path, kSevenScenes + "/frame-000007.color.jpg");
  EXPECT_EQ(dataset->info(7).depth_path, kSevenScenes + "/frame-000007.depth.png");
  EXPECT_DOUBLE_EQ(dataset->rig().colour.fx, 525.0);
  EXPECT_DOUBLE_EQ(dataset->rig().range.camera.fx, 585.0);  // camera-intrinsics.txt agrees
  EXPECT_TRUE(Contains(dataset->calibration_source(), "camera-intrinsics.txt"));
  ASSERT_TRUE(dataset->has_ground_truth());
  EXPECT_EQ(dataset->GroundTruth().size(), 500u);

  std::istringstream pose_text(Slurp(kSevenScenes + "/frame-000000.pose.txt"));
  Eigen::Matrix4d expected;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) pose_text >> expected(r, c);
  }
  ASSERT_TRUE(dataset->info(0).T_w_c_gt.has_value());
  const Eigen::Isometry3d& T = *dataset->info(0).T_w_c_gt;
  EXPECT_LT((T.translation() - expected.topRightCorner<3, 1>()).norm(), 1e-12);
  // The file's rotation is orthonormal to ~2e-4 only (KinectFusion); the reader projects it
  // onto the nearest rotation, which moves its entries by about as much and no more.
  EXPECT_LT((T.linear() - expected.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 2e-4);
  EXPECT_LT((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_EQ(T.matrix().row(3), Eigen::RowVector4d(0, 0, 0, 1));
}

TEST(SevenScenesDataset, DepthIsMillimetresWithZeroInvalid) {
  DatasetOptions options;
  options.format = "7scenes";
  options.first = 250;
  options.last = 250;
  const auto dataset = OpenDataset(kSevenScenes, options);
  ASSERT_EQ(dataset->size(), 1);
  const Frame frame = dataset->Load(0);
  EXPECT_EQ(frame.info.source_index, 250);
  EXPECT_EQ(frame.colour.type(), CV_8UC3);
  EXPECT_EQ(frame.colour.size(), cv::Size(640, 480));
  const cv::Mat raw = cv::imread(kSevenScenes + "/frame-000250.depth.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC1);
  int valid = 0;
  for (int r = 0; r < raw.rows; ++r) {
    for (int c = 0; c < raw.cols; ++c) {
      const int v = raw.at<uint16_t>(r, c);
      const float d = frame.depth.at<float>(r, c);
      if (v == 0 || v == 65535) {
        ASSERT_EQ(d, 0.0f);
      } else if (v >= 300) {
        ASSERT_NEAR(d, v / 1000.0, 1e-6);
        ++valid;
      }
    }
  }
  EXPECT_GT(valid, 0.7 * raw.total());  // the README says ~89% of pixels are valid
}

TEST(SevenScenesDataset, FirstLastStrideSelectFrames) {
  DatasetOptions options;
  options.first = 100;
  options.last = 200;
  options.stride = 10;
  const auto dataset = OpenDataset(kSevenScenes, options);
  ASSERT_EQ(dataset->size(), 11);
  EXPECT_EQ(dataset->total_frames(), 500);
  EXPECT_EQ(dataset->info(0).source_index, 100);
  EXPECT_EQ(dataset->info(10).index, 10);
  EXPECT_EQ(dataset->info(10).source_index, 200);
  EXPECT_DOUBLE_EQ(dataset->info(10).timestamp, 200.0 / 30.0);
  EXPECT_EQ(dataset->info(3).depth_path, kSevenScenes + "/frame-000130.depth.png");
  EXPECT_EQ(dataset->GroundTruth().size(), 11u);

  options.first = 495;
  options.last = 100000;  // past the end: to the end
  options.stride = 2;
  const auto tail = OpenDataset(kSevenScenes, options);
  ASSERT_EQ(tail->size(), 3);
  EXPECT_EQ(tail->info(2).source_index, 499);

  options.first = 500;
  options.last = -1;
  ExpectDataError([&] { OpenDataset(kSevenScenes, options); }, kSevenScenes);
}

// ---------------------------------------------------------------- bad input in a temp dir

TEST_F(DatasetFilesTest, SevenScenesBadPosesAndMissingDepthNameTheFile) {
  for (int i = 0; i < 2; ++i) {
    char stem[32];
    std::snprintf(stem, sizeof(stem), "frame-%06d", i);
    WriteImage(std::string(stem) + ".color.png", Colour(640, 480));
    WriteImage(std::string(stem) + ".depth.png", Depth(640, 480, 1500));
    WriteText(std::string(stem) + ".pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  }
  auto dataset = OpenDataset(dir_, DatasetOptions());
  EXPECT_EQ(dataset->format(), "7scenes");
  EXPECT_EQ(dataset->size(), 2);
  EXPECT_NEAR(dataset->Load(1).depth.at<float>(0, 0), 1.5f, 1e-6);

  const std::string pose =
      WriteText("frame-000001.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 -inf\n0 0 0 1\n");
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, pose);
  WriteText("frame-000001.pose.txt", "2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n");  // a scale
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, pose);
  WriteText("frame-000001.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n");  // 12 numbers
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, pose);
  // The bad pose is skipped when the selection skips its frame.
  DatasetOptions first_only;
  first_only.last = 0;
  EXPECT_EQ(OpenDataset(dir_, first_only)->size(), 1);
}

// A frame missing an image is a frame that fails to load (a counted skip of the run), wherever
// it lies; one missing its pose has no ground truth, with a warning.
TEST_F(DatasetFilesTest, SevenScenesMissingFilesAreSkipsOrFramesWithoutGroundTruth) {
  for (int i = 0; i < 4; ++i) {
    char stem[32];
    std::snprintf(stem, sizeof(stem), "frame-%06d", i);
    WriteImage(std::string(stem) + ".color.png", Colour(640, 480));
    WriteImage(std::string(stem) + ".depth.png", Depth(640, 480, 1500));
    WriteText(std::string(stem) + ".pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  }
  std::filesystem::remove(Path("frame-000001.depth.png"));
  std::filesystem::remove(Path("frame-000002.color.png"));
  std::filesystem::remove(Path("frame-000003.pose.txt"));
  const auto dataset = OpenDataset(dir_, DatasetOptions());
  ASSERT_EQ(dataset->size(), 4);
  EXPECT_NO_THROW(dataset->Load(0));
  ExpectDataError([&] { dataset->Load(1); },
                  "frame 1: range image not found: " + Path("frame-000001.depth.png"));
  ExpectDataError([&] { dataset->Load(2); },
                  "frame 2: colour image not found: " + Path("frame-000002.color.png"));
  EXPECT_NO_THROW(dataset->Load(3));
  EXPECT_TRUE(dataset->info(2).T_w_c_gt.has_value());
  EXPECT_FALSE(dataset->info(3).T_w_c_gt.has_value());
  EXPECT_EQ(dataset->GroundTruth().size(), 3u);
  ASSERT_EQ(dataset->warnings().size(), 1u);
  EXPECT_TRUE(Contains(dataset->warnings()[0], "1 of 4 selected frames have no pose file"))
      << dataset->warnings()[0];
  EXPECT_TRUE(Contains(dataset->warnings()[0], "frame-000003"));

  // Outside the selection, a missing file changes nothing.
  DatasetOptions first_only;
  first_only.last = 0;
  const auto first = OpenDataset(dir_, first_only);
  ASSERT_EQ(first->size(), 1);
  EXPECT_NO_THROW(first->Load(0));
  EXPECT_TRUE(first->warnings().empty());

  // In a sequence of JPEG colour images, the missing one is named as a JPEG.
  for (int i : {0, 1, 3}) {
    char stem[32];
    std::snprintf(stem, sizeof(stem), "frame-%06d", i);
    std::filesystem::rename(Path(std::string(stem) + ".color.png"),
                            Path(std::string(stem) + ".color.jpg"));
  }
  EXPECT_EQ(OpenDataset(dir_, DatasetOptions())->info(2).colour_path,
            Path("frame-000002.color.jpg"));
}

}  // namespace
}  // namespace ieslam
