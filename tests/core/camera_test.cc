#include "core/camera.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

namespace ieslam {
namespace {

PinholeCamera TumFreiburg1() {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = 517.3;
  camera.fy = 516.5;
  camera.cx = 318.6;
  camera.cy = 255.3;
  camera.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  return camera;
}

TEST(CameraTest, ProjectionMatchesOpenCvWithDistortion) {
  const PinholeCamera camera = TumFreiburg1();
  std::vector<cv::Point3d> points = {{0.1, -0.2, 1.5}, {-0.4, 0.3, 2.0}, {0.0, 0.0, 1.0}};
  std::vector<cv::Point2d> expected;
  const cv::Mat K =
      (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(camera.distortion.data()));
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, expected);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d pixel = camera.Project({points[i].x, points[i].y, points[i].z});
    EXPECT_NEAR(pixel.x(), expected[i].x, 1e-9);
    EXPECT_NEAR(pixel.y(), expected[i].y, 1e-9);
  }
}

TEST(CameraTest, UnprojectInvertsProjectAcrossTheImage) {
  const PinholeCamera camera = TumFreiburg1();
  for (double u = 0; u < 640; u += 64) {
    for (double v = 0; v < 480; v += 48) {
      const Eigen::Vector3d ray = camera.Unproject({u, v});
      EXPECT_DOUBLE_EQ(ray.z(), 1.0);
      const Eigen::Vector2d back = camera.Project(ray * 2.5);
      EXPECT_NEAR(back.x(), u, 1e-6);
      EXPECT_NEAR(back.y(), v, 1e-6);
    }
  }
}

TEST(CameraTest, CheckRejectsBadIntrinsics) {
  PinholeCamera camera = TumFreiburg1();
  std::string why;
  EXPECT_TRUE(camera.Check(&why)) << why;
  camera.fx = std::nan("");
  EXPECT_FALSE(camera.Check(&why));
  EXPECT_NE(why.find("NaN"), std::string::npos);
  camera = TumFreiburg1();
  camera.width = 0;
  EXPECT_FALSE(camera.Check(&why));
  camera = TumFreiburg1();
  camera.fy = -1.0;
  EXPECT_FALSE(camera.Check(&why));
}

TEST(CameraTest, RangeImagerConvertsRawValues) {
  RangeImager range;
  range.camera = TumFreiburg1();
  range.camera.distortion = {};
  range.depth_scale = 1.0 / 5000.0;
  range.invalid_values = {0};
  range.min_range_m = 0.2;
  range.max_range_m = 8.0;
  EXPECT_DOUBLE_EQ(range.RawToMetres(5000), 1.0);
  EXPECT_DOUBLE_EQ(range.RawToMetres(0), 0.0);      // invalid
  EXPECT_DOUBLE_EQ(range.RawToMetres(500), 0.0);    // 0.1 m: below min range
  EXPECT_DOUBLE_EQ(range.RawToMetres(65000), 0.0);  // 13 m: beyond max range
  // Z depth: the point's z equals the value; radial: its norm does.
  const Eigen::Vector2d corner(10.0, 20.0);
  EXPECT_DOUBLE_EQ(range.PixelToPoint(corner, 2.0).z(), 2.0);
  range.depth_kind = DepthKind::kRadial;
  EXPECT_NEAR(range.PixelToPoint(corner, 2.0).norm(), 2.0, 1e-12);
}

// The table's points are PixelToPoint's to the bit, with distortion and for both depth
// kinds, over the whole image.
TEST(CameraTest, RangeRaysGiveThePixelToPointBits) {
  for (const DepthKind kind : {DepthKind::kZ, DepthKind::kRadial}) {
    RangeImager range;
    range.camera = TumFreiburg1();
    range.depth_kind = kind;
    const RangeRays rays(range);
    int compared = 0;
    for (int y = 0; y < range.camera.height; y += 7) {
      for (int x = 0; x < range.camera.width; x += 5) {
        const double value = 0.5 + 0.001 * (x + y);
        const Eigen::Vector3d expected = range.PixelToPoint(Eigen::Vector2d(x, y), value);
        ASSERT_EQ(rays.PixelToPoint(x, y, value), expected) << x << ", " << y;
        ++compared;
      }
    }
    EXPECT_GT(compared, 8000);
    // The last pixel too (the table is row-major over the whole image).
    EXPECT_EQ(rays.PixelToPoint(639, 479, 2.0), range.PixelToPoint(Eigen::Vector2d(639, 479), 2.0));
  }
}

TEST(CameraTest, RigCheckValidatesExtrinsicsAndNoise) {
  Rig rig;
  rig.colour = TumFreiburg1();
  rig.range.camera = rig.colour;
  rig.range.noise = {0.001, 0.0, 0.002};
  rig.registered = true;
  std::string why;
  EXPECT_TRUE(rig.Check(&why)) << why;
  rig.T_colour_range.linear() = 2.0 * Eigen::Matrix3d::Identity();
  EXPECT_FALSE(rig.Check(&why));
  EXPECT_NE(why.find("rotation"), std::string::npos);
  rig.T_colour_range = Eigen::Isometry3d::Identity();
  rig.range.noise = {};
  EXPECT_FALSE(rig.Check(&why));
  rig.range.noise = {0.001, 0.0, 0.002};
  rig.range.camera.width = 320;
  EXPECT_FALSE(rig.Check(&why));  // registered needs equal resolutions
}

TEST(CameraTest, RangeNoiseGrowsWithRange) {
  const RangeNoiseModel noise{0.0015, 0.0, 0.0019};
  EXPECT_LT(noise.Sigma(1.0), noise.Sigma(3.0));
  EXPECT_NEAR(noise.Sigma(2.0), 0.0015 + 4 * 0.0019, 1e-15);
}

}  // namespace
}  // namespace ieslam
