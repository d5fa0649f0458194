#include "frontend/dense_map.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/kinect_range_imager.h"
#include "test_files.h"

namespace ieslam {
namespace {

// A registered Kinect-like rig looking at a wall 2 m away, half red, half blue.
struct WallScene {
  Rig rig;
  Frame frame;
  WallScene() {
    rig.range = testing_core::KinectRangeImager();
    rig.colour = rig.range.camera;
    rig.registered = true;
    frame.depth = cv::Mat(480, 640, CV_32F, cv::Scalar(2.0f));
    frame.colour = cv::Mat(480, 640, CV_8UC3, cv::Scalar(255, 0, 0));     // BGR: blue
    frame.colour(cv::Rect(0, 0, 320, 480)).setTo(cv::Scalar(0, 0, 255));  // left half red
  }
};

TEST(DenseMapTest, OnePointPerOccupiedVoxel) {
  const WallScene scene;
  DenseMapOptions options;
  options.voxel_size_m = 0.05;
  options.pixel_step = 4;
  DenseMap map(options);
  map.AddFrame(scene.frame, scene.rig, Eigen::Isometry3d::Identity());
  // The wall seen at 2 m spans 640 / 585 * 2 = 2.19 m by 1.64 m: about 44 x 33 voxels of 5 cm.
  EXPECT_GT(map.size(), 30u * 25u);
  EXPECT_LT(map.size(), 50u * 40u);
  const size_t once = map.size();
  // The same view again falls in the same voxels.
  map.AddFrame(scene.frame, scene.rig, Eigen::Isometry3d::Identity());
  EXPECT_EQ(map.size(), once);
  // Moved by a metre sideways, half of it is new wall.
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
  T_w_c.translation().x() = 1.0;
  map.AddFrame(scene.frame, scene.rig, T_w_c);
  EXPECT_GT(map.size(), once + once / 3);
}

TEST(DenseMapTest, WritesABinaryPlyWithEveryPoint) {
  const WallScene scene;
  DenseMapOptions options;
  options.voxel_size_m = 0.1;
  DenseMap map(options);
  map.AddFrame(scene.frame, scene.rig, Eigen::Isometry3d::Identity());
  const std::string path = ::testing::TempDir() + "/ieslam_dense_map_test.ply";
  map.WritePly(path);
  const std::string ply = testing_files::ReadFile(path);
  EXPECT_EQ(ply.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u) << ply.substr(0, 200);
  EXPECT_NE(ply.find("\nelement vertex " + std::to_string(map.size()) + "\n"), std::string::npos);
  const size_t end = ply.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  // x y z float and red green blue uchar: 15 bytes a point.
  EXPECT_EQ(ply.size() - (end + 11), 15 * map.size());
  std::filesystem::remove(path);
}

TEST(DenseMapTest, RangePixelsWithoutMeasurementAddNothing) {
  WallScene scene;
  scene.frame.depth.setTo(0.0f);
  DenseMap map(DenseMapOptions{});
  map.AddFrame(scene.frame, scene.rig, Eigen::Isometry3d::Identity());
  EXPECT_EQ(map.size(), 0u);
}

TEST(DenseMapTest, OptionsAreChecked) {
  DenseMapOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why));
  options.voxel_size_m = 0.0;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("voxel_size_m"), std::string::npos);
  options = DenseMapOptions();
  options.pixel_step = 0;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("pixel_step"), std::string::npos);
}

}  // namespace
}  // namespace ieslam
