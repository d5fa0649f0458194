#include "core/range_cloud.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/kinect_range_imager.h"

namespace ieslam {
namespace {

using testing_core::PlaneDepth;

TEST(RangeCloudTest, PlaneGivesItsPointsNormalsAndNoise) {
  const RangeImager range = testing_core::KinectRangeImager();
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.1, -1.0).normalized();  // faces the camera
  const double offset = -2.0;  // n . p = -2: about 2 m away
  RangeCloudOptions options;
  const RangeCloud cloud = MakeRangeCloud(PlaneDepth(range, n, offset), range,
                                          Eigen::Isometry3d::Identity(), options, "plane");
  EXPECT_EQ(cloud.grid.width, 160);
  EXPECT_EQ(cloud.grid.height, 120);
  EXPECT_DOUBLE_EQ(cloud.grid.fx, 585.0 / 4);
  // Every grid point but those with more than a third of their 5 x 5 window off the image:
  // the first row and column (10 of 25 off) and the last corner (9 of 25: pixel 640 and row
  // 480 are off).
  EXPECT_EQ(cloud.ValidCount(), 159 * 119 - 1);
  EXPECT_FALSE(cloud.Valid(0));
  for (int index = 0; index < static_cast<int>(cloud.p_r.size()); ++index) {
    if (!cloud.Valid(index)) continue;
    const Eigen::Vector3d p = cloud.p_r[index].cast<double>();
    ASSERT_NEAR(n.dot(p), offset, 1e-5);
    // Float depths (1e-7 relative) over a 7 mm baseline: normals to ~3e-5.
    ASSERT_LT((cloud.n_r[index].cast<double>() - n).norm(), 1e-4);
    ASSERT_NEAR(cloud.sigma_m[index], range.noise.Sigma(p.norm()), 1e-7);
  }
  // A grid point's cell maps back to its own range pixel.
  const int index = 60 * cloud.grid.width + 80;
  const Eigen::Vector2d pixel = range.camera.Project(cloud.p_r[index].cast<double>());
  EXPECT_NEAR(pixel.x(), 320.0, 1e-3);
  EXPECT_NEAR(pixel.y(), 240.0, 1e-3);
}

TEST(RangeCloudTest, InterpolationFollowsThePlaneBetweenGridPoints) {
  const RangeImager range = testing_core::KinectRangeImager();
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, 0.2, -1.0).normalized();
  const RangeCloud cloud =
      MakeRangeCloud(PlaneDepth(range, n, -1.5), range, Eigen::Isometry3d::Identity(),
                     RangeCloudOptions(), "plane");
  // Off-grid directions: the interpolated point lies on the plane (a plane is linear in the
  // pixel grid's bilinear patches only approximately: within a micrometre at this size).
  for (const Eigen::Vector2d& pixel :
       {Eigen::Vector2d(101.3, 57.9), Eigen::Vector2d(400.5, 300.25)}) {
    const Eigen::Vector3d ray = range.camera.Unproject(pixel);
    const Eigen::Vector3d p = ray * (-1.5 / n.dot(ray)) + 0.01 * n;  // 1 cm in front of it
    Eigen::Vector3d q, normal;
    double sigma = 0.0;
    ASSERT_TRUE(cloud.Interpolate(p, 0.05, &q, &normal, &sigma));
    EXPECT_NEAR(n.dot(q), -1.5, 1e-6);
    EXPECT_LT((normal - n).norm(), 1e-4);
    EXPECT_NEAR(n.dot(p - q), 0.01, 1e-6);  // the point-to-plane distance
    EXPECT_NEAR(sigma, range.noise.Sigma(q.norm()), 1e-4);
  }
  Eigen::Vector3d q, normal;
  double sigma = 0.0;
  EXPECT_FALSE(cloud.Interpolate(Eigen::Vector3d(0, 0, -1), 0.05, &q, &normal, &sigma));  // behind
  EXPECT_FALSE(cloud.Interpolate(Eigen::Vector3d(10, 0, 1), 0.05, &q, &normal, &sigma));  // outside
}

TEST(RangeCloudTest, DepthEdgesInvalidPointsAndObliqueSurfacesAreLeftOut) {
  const RangeImager range = testing_core::KinectRangeImager();
  cv::Mat depth(480, 640, CV_32FC1, cv::Scalar(2.0f));
  depth.colRange(320, 640).setTo(1.0f);  // a step of 1 m at column 320
  depth.at<float>(100, 100) = 0.0f;      // no measurement
  depth.at<float>(200, 200) = std::numeric_limits<float>::quiet_NaN();
  const RangeCloud cloud =
      MakeRangeCloud(depth, range, Eigen::Isometry3d::Identity(), RangeCloudOptions(), "step");
  const int w = cloud.grid.width;
  EXPECT_TRUE(cloud.Valid(60 * w + 78));   // column 312: 8 px from the edge
  EXPECT_FALSE(cloud.Valid(60 * w + 80));  // column 320: its left neighbour is 1 m away
  EXPECT_TRUE(cloud.Valid(60 * w + 82));
  EXPECT_FALSE(cloud.Valid(25 * w + 25));  // pixel (100, 100) itself
  EXPECT_FALSE(cloud.Valid(50 * w + 50));  // pixel (200, 200)
  Eigen::Vector3d q, normal;
  double sigma = 0.0;
  // Across the edge the four grid points lie on two surfaces.
  EXPECT_FALSE(cloud.Interpolate(Eigen::Vector3d(-0.002, 0.0, 1.5), 0.05, &q, &normal, &sigma));

  // A plane seen at 80 deg from face-on: beyond max_incidence_deg (75), left out entirely.
  const Eigen::Vector3d oblique(std::sin(80.0 * M_PI / 180), 0.0, -std::cos(80.0 * M_PI / 180));
  const RangeCloud grazing = MakeRangeCloud(PlaneDepth(range, oblique, -0.5), range,
                                            Eigen::Isometry3d::Identity(), RangeCloudOptions(), "");
  int near_axis = 0;
  for (int gy = 50; gy < 70; ++gy) near_axis += grazing.Valid(gy * w + 80) ? 1 : 0;
  EXPECT_EQ(near_axis, 0);
}

TEST(RangeCloudTest, InterpolationRefusesCreasesAndDepthSpreads) {
  const RangeImager range = testing_core::KinectRangeImager();
  // A corner: the planes z = 2 + x (left) and z = 2 - x (right) meet in a 90 deg crease
  // 2 m ahead, along the image's middle column.
  cv::Mat depth(480, 640, CV_32FC1);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 640; ++x) {
      const double u = (x - 320.0) / 585.0;  // x / z
      depth.at<float>(y, x) = static_cast<float>(u < 0 ? 2.0 / (1.0 - u) : 2.0 / (1.0 + u));
    }
  }
  const RangeCloud cloud =
      MakeRangeCloud(depth, range, Eigen::Isometry3d::Identity(), RangeCloudOptions(), "corner");
  Eigen::Vector3d q, normal;
  double sigma = 0.0;
  // Well inside either plane: its own surface and normal.
  ASSERT_TRUE(cloud.Interpolate(Eigen::Vector3d(-0.4, 0.01, 1.6), 0.05, &q, &normal, &sigma));
  EXPECT_LT((normal - Eigen::Vector3d(1, 0, -1).normalized()).norm(), 1e-3);
  // At the crease the grid points' normals disagree by 90 deg (or the crease's own points
  // are not flat): no surface there.
  EXPECT_FALSE(cloud.Interpolate(Eigen::Vector3d(0.003, 0.01, 1.997), 0.05, &q, &normal, &sigma));
  // A tight depth-spread limit refuses a slanted plane's four grid points, a loose one not.
  const Eigen::Vector3d n = Eigen::Vector3d(0.6, 0.0, -0.8);
  const RangeCloud slanted = MakeRangeCloud(PlaneDepth(range, n, -1.6), range,
                                            Eigen::Isometry3d::Identity(), RangeCloudOptions(), "");
  const Eigen::Vector3d p =
      Eigen::Vector3d(0.05, 0.0, 1.0) * (-1.6 / n.dot(Eigen::Vector3d(0.05, 0, 1)));
  EXPECT_TRUE(slanted.Interpolate(p, 0.05, &q, &normal, &sigma));
  EXPECT_FALSE(slanted.Interpolate(p, 1e-4, &q, &normal, &sigma));
}

// The rays' table gives the same cloud, bit for bit, with a distorted imager and edges.
TEST(RangeCloudTest, TheRaysTableGivesTheSameCloud) {
  RangeImager range = testing_core::KinectRangeImager();
  range.camera.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  cv::Mat depth = PlaneDepth(range, Eigen::Vector3d(0.2, -0.1, -1.0).normalized(), -2.0);
  depth.colRange(400, 640).setTo(1.2f);
  const RangeRays rays(range);
  const RangeCloud plain =
      MakeRangeCloud(depth, range, Eigen::Isometry3d::Identity(), RangeCloudOptions(), "plain");
  const RangeCloud tabled = MakeRangeCloud(depth, range, Eigen::Isometry3d::Identity(),
                                           RangeCloudOptions(), "tabled", &rays);
  ASSERT_EQ(plain.p_r.size(), tabled.p_r.size());
  EXPECT_GT(plain.ValidCount(), 10000);
  EXPECT_EQ(plain.ValidCount(), tabled.ValidCount());
  for (size_t i = 0; i < plain.p_r.size(); ++i) {
    if (!plain.Valid(static_cast<int>(i))) continue;
    ASSERT_EQ(plain.p_r[i], tabled.p_r[i]) << i;
    ASSERT_EQ(plain.n_r[i], tabled.n_r[i]) << i;
    ASSERT_EQ(plain.sigma_m[i], tabled.sigma_m[i]) << i;
  }
}

// A rolling shutter turning about the vertical axis sees a wall from another pose on each row.
// With the rows' motion the cloud is the wall as seen from the frame's pose, and a point of the
// wall finds itself on it, through the row that saw it.
TEST(RangeCloudTest, RowMotionPlacesARollingShuttersRowsAndAssociatesThroughThem) {
  const RangeImager range = testing_core::KinectRangeImager();
  // 1.5 rad/s about y (86 deg/s), a 30 ms readout.
  const RangeRowMotion motion = testing_core::TurningRowMotion(range, 1.5, 0.03);
  // The wall z = 2 of the frame's pose, as each row sees it: n . (M p_row) = 2.
  cv::Mat depth(range.camera.height, range.camera.width, CV_32FC1);
  for (int y = 0; y < depth.rows; ++y) {
    const Eigen::Vector3d n_row = motion(y).linear().transpose() * Eigen::Vector3d::UnitZ();
    for (int x = 0; x < depth.cols; ++x) {
      const Eigen::Vector3d ray = range.camera.Unproject(Eigen::Vector2d(x, y));
      depth.at<float>(y, x) = static_cast<float>(2.0 / n_row.dot(ray));
    }
  }
  RangeCloudOptions options;
  const RangeCloud rolled =
      MakeRangeCloud(depth, range, Eigen::Isometry3d::Identity(), options, "wall", nullptr, motion);
  const RangeCloud as_global =
      MakeRangeCloud(depth, range, Eigen::Isometry3d::Identity(), options, "wall");
  ASSERT_EQ(rolled.to_row.size(), static_cast<size_t>(rolled.grid.height));
  EXPECT_TRUE(as_global.to_row.empty());
  double rolled_off = 0.0, global_off = 0.0;
  for (size_t i = 0; i < rolled.p_r.size(); ++i) {
    if (!rolled.Valid(static_cast<int>(i))) continue;
    rolled_off = std::max(rolled_off, std::abs(rolled.p_r[i].z() - 2.0));
    global_off = std::max(global_off, std::abs(as_global.p_r[i].z() - 2.0));
    // A normal is fitted to its window's points as their rows saw them, which the turn shears
    // across the rows: a few degrees off, which moves a point-to-plane residual by microns.
    EXPECT_GT(-rolled.n_r[i].z(), std::cos(3.0 * M_PI / 180.0));
  }
  EXPECT_LT(rolled_off, 1e-5);  // float rounding
  EXPECT_GT(global_off, 0.02);  // the rows turned by up to 1.3 deg: a sheared wall
  for (const Eigen::Vector3d p : {Eigen::Vector3d(0.7, -0.5, 2.0), Eigen::Vector3d(-0.6, 0.6, 2.0),
                                  Eigen::Vector3d(0.0, 0.0, 2.0)}) {
    Eigen::Vector3d q, n;
    double sigma = 0.0;
    ASSERT_TRUE(rolled.Interpolate(p, 0.05, &q, &n, &sigma)) << p.transpose();
    // On the wall, and beside the point by a fraction of a millimetre (the corners' rows are
    // taken at the nearest grid row's motion), where the frame's pose alone would put it
    // centimetres away.
    EXPECT_LT(std::abs(q.z() - 2.0), 1e-5) << p.transpose() << " -> " << q.transpose();
    EXPECT_LT((q - p).norm(), 1e-3) << p.transpose() << " -> " << q.transpose();
  }
}

TEST(RangeCloudTest, WrongSizeOrBadOptionsAreErrors) {
  const RangeImager range = testing_core::KinectRangeImager();
  try {
    MakeRangeCloud(cv::Mat(240, 320, CV_32FC1, cv::Scalar(1.0f)), range,
                   Eigen::Isometry3d::Identity(), RangeCloudOptions(), "frame 7");
    FAIL() << "no error for a 320x240 range image";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("frame 7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("320x240"), std::string::npos) << e.what();
  }
  RangeCloudOptions bad;
  bad.step = 0;
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("step"), std::string::npos);
  bad = RangeCloudOptions();
  bad.max_incidence_deg = 90.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(MakeRangeCloud(cv::Mat(480, 640, CV_32FC1, cv::Scalar(1.0f)), range,
                              Eigen::Isometry3d::Identity(), bad, "frame 7"),
               ConfigError);
}

}  // namespace
}  // namespace ieslam
