#include "frontend/simulation/scene_renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "frontend/simulation/synthetic_dataset.h"
#include "frontend/simulation/synthetic_trajectory.h"

namespace ieslam {
namespace {

PinholeCamera SmallCamera() {
  PinholeCamera camera;
  camera.width = 160;
  camera.height = 120;
  camera.fx = camera.fy = 131.25;
  camera.cx = 79.5;
  camera.cy = 59.5;
  return camera;
}

Eigen::Isometry3d Pose(const Eigen::Vector3d& t, double heading, double pitch, double roll) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = LookRotation(heading, pitch, roll);
  T.translation() = t;
  return T;
}

TEST(SceneRendererTest, BadOptionsCamerasAndImagersThrowConfigError) {
  SyntheticSceneOptions scene_options;
  scene_options.box_count = 0;
  const SyntheticScene scene(scene_options);
  const Eigen::Isometry3d T_w_c = Pose(Eigen::Vector3d(0, 0, 1.5), 0.0, 0.0, 0.0);
  RenderOptions bad_options;
  bad_options.edge_supersampling = 0;
  EXPECT_THROW(RenderView(scene, SmallCamera(), T_w_c, bad_options), ConfigError);
  PinholeCamera bad_camera = SmallCamera();
  bad_camera.fx = 0.0;
  EXPECT_THROW(RenderView(scene, bad_camera, T_w_c, RenderOptions()), ConfigError);

  RangeImager imager;
  imager.camera = SmallCamera();
  imager.noise = {0.005, 0.01, 0.0};
  RenderOptions geometry;
  geometry.colour = false;
  const RenderedView view = RenderView(scene, imager.camera, T_w_c, geometry);
  std::mt19937 rng(1);
  RangeSensorModel bad_model;
  bad_model.max_incidence_deg = 95.0;
  EXPECT_THROW(SimulateRangeImage(view, imager, bad_model, &rng), ConfigError);
  RangeImager bad_imager = imager;
  bad_imager.max_range_m = 0.05;  // below min_range_m
  EXPECT_THROW(SimulateRangeImage(view, bad_imager, RangeSensorModel(), &rng), ConfigError);
  EXPECT_NO_THROW(SimulateRangeImage(view, imager, RangeSensorModel(), &rng));
}

TEST(SceneRendererTest, FrontoParallelWallHasConstantDepth) {
  SyntheticSceneOptions options;
  options.box_count = 0;
  options.board_count = 0;
  const SyntheticScene scene(options);
  const PinholeCamera camera = SmallCamera();
  // Looking straight at the +x wall (x = 3) from x = 1: every pixel sees it at z = 2.
  const RenderedView view = RenderView(scene, camera, Pose({1.0, 0.2, 1.5}, 0.0, 0.0, 0.0), {});
  for (int r = 0; r < camera.height; ++r) {
    for (int c = 0; c < camera.width; ++c) {
      ASSERT_EQ(view.surface.at<int>(r, c), kWallPlusX);
      ASSERT_NEAR(view.z_m.at<double>(r, c), 2.0, 1e-12);
      const Eigen::Vector3d ray = camera.Unproject(Eigen::Vector2d(c, r));
      ASSERT_NEAR(view.range_m.at<double>(r, c), 2.0 * ray.norm(), 1e-12);
      ASSERT_NEAR(view.cos_incidence.at<double>(r, c), 1.0 / ray.norm(), 1e-12);
    }
  }
}

// Every pixel's depth, back-projected, lies on the plane of the surface it reports, for an
// oblique, rolled view with boxes and boards in it.
TEST(SceneRendererTest, DepthIsTheAnalyticDistanceToEachPlane) {
  const SyntheticScene scene{SyntheticSceneOptions()};
  PinholeCamera camera = SmallCamera();
  camera.distortion = {-0.1, 0.02, 0.0, 0.0, 0.0};  // rays through the distortion model
  const Eigen::Isometry3d T_w_c = Pose({0.5, -0.3, 1.3}, 2.5, -0.3, 0.2);
  const RenderedView view = RenderView(scene, camera, T_w_c, {});
  const Eigen::Vector3d lo = scene.room_min_w(), hi = scene.room_max_w();
  int on_boxes = 0;
  for (int r = 0; r < camera.height; r += 3) {
    for (int c = 0; c < camera.width; c += 3) {
      const int surface = view.surface.at<int>(r, c);
      const double z = view.z_m.at<double>(r, c);
      const Eigen::Vector3d p_w = T_w_c * (z * camera.Unproject(Eigen::Vector2d(c, r)));
      // The pixel projects back to itself.
      const Eigen::Vector2d back = camera.Project(T_w_c.inverse() * p_w);
      ASSERT_NEAR(back.x(), c, 1e-6);
      ASSERT_NEAR(back.y(), r, 1e-6);
      switch (surface) {
        case kFloor:
          ASSERT_NEAR(p_w.z(), lo.z(), 1e-9);
          continue;
        case kCeiling:
          ASSERT_NEAR(p_w.z(), hi.z(), 1e-9);
          continue;
        case kWallMinusX:
          ASSERT_NEAR(p_w.x(), lo.x(), 1e-9);
          continue;
        case kWallPlusX:
          ASSERT_NEAR(p_w.x(), hi.x(), 1e-9);
          continue;
        case kWallMinusY:
          ASSERT_NEAR(p_w.y(), lo.y(), 1e-9);
          continue;
        case kWallPlusY:
          ASSERT_NEAR(p_w.y(), hi.y(), 1e-9);
          continue;
        default:
          break;
      }
      for (const SceneBox& box : scene.boxes()) {
        if (surface < box.first_surface || surface >= box.first_surface + 6) continue;
        const int face = surface - box.first_surface;
        // The face's plane through corner 0 or 7 with the face's outward normal.
        const Eigen::Vector3d corner = box.Corner(face % 2 == 0 ? 0 : 7);
        const Eigen::Vector3d edge = box.Corner(face / 2 == 0   ? 1
                                                : face / 2 == 1 ? 2
                                                                : 4) -
                                     box.Corner(0);
        ASSERT_NEAR((p_w - corner).dot(edge.normalized()), 0.0, 1e-9);
        ++on_boxes;
      }
      for (const SceneBoard& board : scene.boards()) {
        if (surface != board.surface) continue;
        const Eigen::Vector3d n = board.axis_u_w.cross(board.axis_v_w);
        ASSERT_NEAR((p_w - board.origin_w).dot(n), 0.0, 1e-9);
      }
    }
  }
  EXPECT_GT(on_boxes, 20);
}

TEST(SceneRendererTest, ThreadCountDoesNotChangeTheImages) {
  const SyntheticScene scene{SyntheticSceneOptions()};
  const PinholeCamera camera = SmallCamera();
  const Eigen::Isometry3d T_w_c = SyntheticTrajectoryPose(SyntheticTrajectoryOptions(), 40, 300);
  RenderOptions one;
  RenderOptions three;
  three.threads = 3;
  const RenderedView a = RenderView(scene, camera, T_w_c, one);
  const RenderedView b = RenderView(scene, camera, T_w_c, three);
  EXPECT_EQ(cv::norm(a.colour, b.colour, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.z_m, b.z_m, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.surface, b.surface, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a.colour, cv::NORM_L1), 0.0);
}

TEST(SceneRendererTest, RangeImageInvalidatesGrazingPixelsAndQuantises) {
  const SyntheticScene scene{SyntheticSceneOptions()};
  const Rig rig = SyntheticRig(SyntheticSensor::kRgbd, 0.25);
  // Level and low over the floor: the far floor is seen at grazing angles.
  const RenderedView view = RenderView(scene, rig.colour, Pose({0.0, 0.0, 0.3}, 0.3, 0.0, 0.0), {});
  std::mt19937 rng(1);
  const cv::Mat raw = SimulateRangeImage(view, rig.range, {75.0, /*add_noise=*/false}, &rng);
  const double min_cos = std::cos(75.0 * M_PI / 180.0);
  int grazing = 0, valid = 0;
  for (int r = 0; r < raw.rows; ++r) {
    for (int c = 0; c < raw.cols; ++c) {
      const double z = view.z_m.at<double>(r, c);
      const bool in_range = z >= rig.range.min_range_m && z <= rig.range.max_range_m;
      if (view.cos_incidence.at<double>(r, c) < min_cos) {
        ++grazing;
        EXPECT_EQ(raw.at<uint16_t>(r, c), 0);
      } else if (in_range) {
        ++valid;
        EXPECT_EQ(raw.at<uint16_t>(r, c), std::lround(z * 5000.0));
      } else {
        EXPECT_EQ(raw.at<uint16_t>(r, c), 0);
      }
    }
  }
  EXPECT_GT(grazing, 50);
  EXPECT_GT(valid, 5000);
}

TEST(SceneRendererTest, RangeNoiseFollowsTheImagersModel) {
  const SyntheticScene scene{SyntheticSceneOptions()};
  const Rig rig = SyntheticRig(SyntheticSensor::kPair, 1.0);
  const Eigen::Isometry3d T_w_r = SyntheticTrajectoryPose(SyntheticTrajectoryOptions(), 0, 300);
  const RenderedView view = RenderView(scene, rig.range.camera, T_w_r, {});
  std::mt19937 rng(5);
  const cv::Mat raw = SimulateRangeImage(view, rig.range, {}, &rng);
  double sum = 0.0, sum_sq = 0.0;
  int n = 0;
  for (int r = 0; r < raw.rows; ++r) {
    for (int c = 0; c < raw.cols; ++c) {
      if (raw.at<uint16_t>(r, c) == 0) continue;
      const double d = view.range_m.at<double>(r, c);  // radial, as the SR-3000 reports
      const double e =
          (raw.at<uint16_t>(r, c) * rig.range.depth_scale - d) / rig.range.noise.Sigma(d);
      sum += e;
      sum_sq += e * e;
      ++n;
    }
  }
  ASSERT_GT(n, 20000);
  EXPECT_NEAR(sum / n, 0.0, 0.03);
  EXPECT_NEAR(std::sqrt(sum_sq / n), 1.0, 0.03);
}

TEST(SceneRendererTest, SiftFindsPlentyOfKeypointsInAFullFrame) {
  const SyntheticScene scene{SyntheticSceneOptions()};
  const Rig rig = SyntheticRig(SyntheticSensor::kRgbd, 1.0);
  RenderOptions options;
  options.threads = 2;
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create();
  for (int frame : {0, 150}) {
    const RenderedView view =
        RenderView(scene, rig.colour,
                   SyntheticTrajectoryPose(SyntheticTrajectoryOptions(), frame, 300), options);
    cv::Mat grey;
    cv::cvtColor(view.colour, grey, cv::COLOR_BGR2GRAY);
    std::vector<cv::KeyPoint> keypoints;
    sift->detect(grey, keypoints);
    EXPECT_GE(keypoints.size(), 300u) << "frame " << frame;
    // Spread over the image, not bunched on a few edges: every quarter of the image has some.
    int quarters[4] = {0, 0, 0, 0};
    for (const cv::KeyPoint& k : keypoints) {
      ++quarters[(k.pt.x < 320 ? 0 : 1) + (k.pt.y < 240 ? 0 : 2)];
    }
    for (int q : quarters) EXPECT_GE(q, 30) << "frame " << frame;
  }
}

TEST(SceneRendererTest, ColourNoiseHasTheRequestedSigma) {
  cv::Mat grey(200, 200, CV_8UC3, cv::Scalar(100, 120, 140));
  std::mt19937 rng(9);
  const cv::Mat noisy = AddColourNoise(grey, 2.0, &rng);
  cv::Mat difference;
  cv::subtract(noisy, grey, difference, cv::noArray(), CV_32FC3);
  cv::Scalar mean, stddev;
  cv::meanStdDev(difference.reshape(1), mean, stddev);
  EXPECT_NEAR(mean[0], 0.0, 0.05);
  EXPECT_NEAR(stddev[0], std::sqrt(4.0 + 1.0 / 12.0), 0.1);  // plus rounding
  EXPECT_EQ(cv::norm(AddColourNoise(grey, 0.0, &rng), grey, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace ieslam
