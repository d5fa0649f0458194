#include "frontend/simulation/synthetic_dataset.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <thread>

#include <unistd.h>

#include "core/calibration.h"
#include "core/dataset.h"
#include "core/error.h"
#include "core/file_util.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() /
                       ("ieslam_synthetic_dataset_test_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  return dir.string();
}

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

SyntheticDatasetOptions SmallOptions(SyntheticSensor sensor) {
  SyntheticDatasetOptions options;
  options.sensor = sensor;
  options.frames = 5;
  options.resolution_scale = sensor == SyntheticSensor::kRgbd ? 0.25 : 0.5;
  options.threads = 2;
  return options;
}

TEST(SyntheticDatasetTest, OptionsAndSensorNames) {
  std::string why;
  EXPECT_TRUE(SyntheticDatasetOptions().Check(&why)) << why;
  SyntheticDatasetOptions bad;
  bad.frames = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("frames"), std::string::npos) << why;
  bad = SyntheticDatasetOptions();
  bad.resolution_scale = 0.03;  // a 19x14 image
  EXPECT_FALSE(bad.Check(&why));
  bad = SyntheticDatasetOptions();
  bad.trajectory.yaw_wobble_cycles = -1;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(WriteSyntheticDataset(TempDir("bad"), bad), ConfigError);
  const SyntheticScene scene{SyntheticSceneOptions()};
  EXPECT_THROW(
      RenderSyntheticFrame(scene, SyntheticRig(bad.sensor), Eigen::Isometry3d::Identity(), bad, 0),
      ConfigError);
  EXPECT_EQ(ParseSyntheticSensor("pair"), SyntheticSensor::kPair);
  EXPECT_EQ(std::string(ToString(ParseSyntheticSensor("rgbd"))), "rgbd");
  EXPECT_THROW(ParseSyntheticSensor("kinect"), ConfigError);
}

TEST(SyntheticDatasetTest, RigsAreTheDocumentedSensors) {
  const Rig rgbd = SyntheticRig(SyntheticSensor::kRgbd);
  EXPECT_TRUE(rgbd.registered);
  EXPECT_EQ(rgbd.colour.width, 640);
  EXPECT_EQ(rgbd.colour.fx, 525.0);
  EXPECT_EQ(rgbd.colour.cx, 319.5);
  EXPECT_EQ(rgbd.range.depth_scale, 1.0 / 5000.0);
  EXPECT_EQ(rgbd.range.depth_kind, DepthKind::kZ);
  const Rig pair = SyntheticRig(SyntheticSensor::kPair);
  EXPECT_FALSE(pair.registered);
  EXPECT_EQ(pair.colour.width, 1024);
  EXPECT_EQ(pair.range.camera.width, 176);
  EXPECT_EQ(pair.range.depth_kind, DepthKind::kRadial);
  const double fov_x = 2.0 * std::atan(88.0 / pair.range.camera.fx) * 180.0 / M_PI;
  const double fov_y = 2.0 * std::atan(72.0 / pair.range.camera.fy) * 180.0 / M_PI;
  EXPECT_NEAR(fov_x, 43.0, 1.0);
  EXPECT_NEAR(fov_y, 35.0, 1.0);
  EXPECT_NEAR(pair.T_colour_range.translation().norm(), 0.05, 1e-12);
  // Scaling keeps the field of view: the image edge stays at the same angle.
  const Rig quarter = SyntheticRig(SyntheticSensor::kRgbd, 0.25);
  EXPECT_EQ(quarter.colour.width, 160);
  EXPECT_NEAR((-0.5 - quarter.colour.cx) / quarter.colour.fx,
              (-0.5 - rgbd.colour.cx) / rgbd.colour.fx, 1e-12);
}

TEST(SyntheticDatasetTest, CameraSeesTheRoomOneToFourMetresAway) {
  SyntheticDatasetOptions options;
  options.resolution_scale = 0.25;
  const SyntheticScene scene(options.scene);
  const Rig rig = SyntheticRig(options.sensor, options.resolution_scale);
  for (int i = 0; i < 300; i += 30) {
    const SyntheticFrame frame = RenderSyntheticFrame(
        scene, rig, SyntheticTrajectoryPose(options.trajectory, i, 300), options, i);
    std::vector<double> z(frame.colour_view.z_m.begin<double>(),
                          frame.colour_view.z_m.end<double>());
    std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
    EXPECT_GT(z[z.size() / 2], 1.0) << "frame " << i;
    EXPECT_LT(z[z.size() / 2], 4.0) << "frame " << i;
    EXPECT_GT(cv::countNonZero(frame.range_raw), frame.range_raw.total() * 8 / 10) << "frame " << i;
  }
}

// A box corner seen by both cameras of the pair lands where the rig says in both images,
// and the range image's radial distances put the corner where it is.
TEST(SyntheticDatasetTest, PairBoxCornerProjectsConsistentlyIntoBothImages) {
  SyntheticDatasetOptions options = SmallOptions(SyntheticSensor::kPair);
  options.resolution_scale = 1.0;
  options.add_noise = false;
  const SyntheticScene scene(options.scene);
  const Rig rig = SyntheticRig(options.sensor);
  int corners_checked = 0;
  for (const SceneBox& box : scene.boxes()) {
    // A top corner on the room's side of the box, looked at from 1.3 m away, above and out.
    for (int i = 4; i < 8 && corners_checked < 3; ++i) {
      const Eigen::Vector3d corner = box.Corner(i);
      Eigen::Vector3d out = corner - box.centre_w;
      out.z() = 0.0;
      out.normalize();
      const Eigen::Vector3d to_centre =
          Eigen::Vector3d(-box.centre_w.x(), -box.centre_w.y(), 0).normalized();
      if (out.dot(to_centre) < 0.3) continue;
      const Eigen::Vector3d eye = corner + 1.3 * (out + Eigen::Vector3d(0, 0, 0.6)).normalized();
      const Eigen::Vector3d look = corner - eye;
      if (!scene.IsFreeSpace(eye, 0.3) || scene.Intersect(eye, look).t < 1.0 - 1e-6) continue;
      Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
      T_w_c.linear() = LookRotation(std::atan2(look.y(), look.x()),
                                    std::atan2(look.z(), look.head<2>().norm()), 0.1);
      T_w_c.translation() = eye;
      const SyntheticFrame frame = RenderSyntheticFrame(scene, rig, T_w_c, options, 0);
      const Eigen::Isometry3d T_w_r = T_w_c * rig.T_colour_range;
      struct View {
        const PinholeCamera* camera;
        Eigen::Isometry3d T_w;
        const RenderedView* rendered;
      } views[2] = {{&rig.colour, T_w_c, &frame.colour_view},
                    {&rig.range.camera, T_w_r, &frame.range_view}};
      for (const View& view : views) {
        const Eigen::Vector2d pixel = view.camera->Project(view.T_w.inverse() * corner);
        const int u = static_cast<int>(std::lround(pixel.x())),
                  v = static_cast<int>(std::lround(pixel.y()));
        ASSERT_TRUE(view.camera->InImage(pixel, 2.0));
        // The three faces meeting at the corner all appear within a pixel of it.
        std::set<int> faces;
        for (int dv = -1; dv <= 1; ++dv) {
          for (int du = -1; du <= 1; ++du) {
            const int s = view.rendered->surface.at<int>(v + dv, u + du);
            if (s >= box.first_surface && s < box.first_surface + 6) faces.insert(s);
          }
        }
        EXPECT_EQ(faces.size(), 3u)
            << "camera " << view.camera->width << " box " << box.first_surface;
      }
      // The range pixel at the corner, through its raw radial value and the extrinsics,
      // lands on the corner (within the imager's ~6 mm pixel footprint at 1.3 m).
      const Eigen::Vector2d pixel = rig.range.camera.Project(T_w_r.inverse() * corner);
      double best = 1e9;
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const Eigen::Vector2d p(std::lround(pixel.x()) + du, std::lround(pixel.y()) + dv);
          const int raw =
              frame.range_raw.at<uint16_t>(static_cast<int>(p.y()), static_cast<int>(p.x()));
          const Eigen::Vector3d p_w = T_w_r * rig.range.PixelToPoint(p, rig.range.RawToMetres(raw));
          const int s =
              frame.range_view.surface.at<int>(static_cast<int>(p.y()), static_cast<int>(p.x()));
          if (s < box.first_surface || s >= box.first_surface + 6) continue;  // background
          // ... and projects into the colour image next to where the corner does (one range
          // pixel is 3.6 colour pixels).
          const Eigen::Vector2d in_colour = rig.colour.Project(T_w_c.inverse() * p_w);
          EXPECT_LT((in_colour - rig.colour.Project(T_w_c.inverse() * corner)).norm(), 7.0);
          best = std::min(best, (p_w - corner).norm());
        }
      }
      EXPECT_LT(best, 0.012);
      ++corners_checked;
    }
  }
  EXPECT_GE(corners_checked, 3);
}

void ExpectRoundTrip(SyntheticSensor sensor, const std::string& format) {
  const SyntheticDatasetOptions options = SmallOptions(sensor);
  const std::string dir = TempDir(format);
  WriteSyntheticDataset(dir, options);
  const std::unique_ptr<Dataset> dataset = OpenDataset(dir, DatasetOptions());
  EXPECT_EQ(dataset->format(), format);
  // The rig comes from the calib.yaml written, not from a default for the format.
  EXPECT_EQ(dataset->calibration_path(), JoinPath(dir, "calib.yaml"));
  ASSERT_EQ(dataset->size(), 5);
  ASSERT_TRUE(dataset->has_ground_truth());
  const Rig rig = SyntheticRig(sensor, options.resolution_scale);
  EXPECT_EQ(dataset->rig().colour.width, rig.colour.width);
  EXPECT_EQ(dataset->rig().range.camera.width, rig.range.camera.width);
  EXPECT_NEAR(dataset->rig().colour.fx, rig.colour.fx, 1e-12);
  EXPECT_LT((dataset->rig().T_colour_range.matrix() - rig.T_colour_range.matrix()).norm(), 1e-12);
  const SyntheticScene scene(options.scene);
  for (int i = 0; i < 5; ++i) {
    const Frame loaded = dataset->Load(i);
    const Eigen::Isometry3d T_w_c = SyntheticTrajectoryPose(options.trajectory, i, options.frames);
    const SyntheticFrame frame = RenderSyntheticFrame(scene, rig, T_w_c, options, i);
    EXPECT_NEAR(loaded.info.timestamp, 1000.0 + i / 30.0, 1e-6);
    EXPECT_EQ(cv::norm(loaded.colour, frame.colour, cv::NORM_INF), 0.0) << "frame " << i;
    cv::Mat metres;
    frame.range_raw.convertTo(metres, CV_32F, rig.range.depth_scale);
    EXPECT_LT(cv::norm(loaded.depth, metres, cv::NORM_INF), 1e-6) << "frame " << i;
    ASSERT_TRUE(loaded.info.T_w_c_gt.has_value());
    EXPECT_LT((loaded.info.T_w_c_gt->matrix() - T_w_c.matrix()).norm(), 1e-6) << "frame " << i;
  }
  fs::remove_all(dir);
}

TEST(SyntheticDatasetTest, RgbdDatasetRoundTripsThroughTheTumReader) {
  ExpectRoundTrip(SyntheticSensor::kRgbd, "tum");
}

TEST(SyntheticDatasetTest, PairDatasetRoundTripsThroughThePairReader) {
  ExpectRoundTrip(SyntheticSensor::kPair, "pair");
}

TEST(SyntheticDatasetTest, SameOptionsGiveByteIdenticalFilesWhateverTheThreads) {
  SyntheticDatasetOptions options = SmallOptions(SyntheticSensor::kRgbd);
  options.frames = 3;
  const std::string a = TempDir("same_a"), b = TempDir("same_b"), c = TempDir("other_noise");
  WriteSyntheticDataset(a, options);
  options.threads = 1;
  WriteSyntheticDataset(b, options);
  options.noise_seed = 99;
  WriteSyntheticDataset(c, options);
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(a)) {
    if (!entry.is_regular_file()) continue;
    const fs::path relative = fs::relative(entry.path(), a);
    EXPECT_EQ(ReadBytes(entry.path()), ReadBytes(fs::path(b) / relative)) << relative;
    ++files;
  }
  EXPECT_EQ(files, 3 * 2 + 5);  // images, lists, groundtruth, calib, synthetic.txt
  const std::string depth = "depth/1000.000000.png";
  EXPECT_NE(ReadBytes(fs::path(a) / depth), ReadBytes(fs::path(c) / depth));
  EXPECT_EQ(ReadBytes(fs::path(a) / "groundtruth.txt"), ReadBytes(fs::path(c) / "groundtruth.txt"));
  for (const std::string& dir : {a, b, c}) fs::remove_all(dir);
}

// A stop request closes the dataset with the frames rendered so far: a complete, shorter one.
TEST(SyntheticDatasetTest, AStopRequestLeavesAShorterCompleteDataset) {
  SyntheticDatasetOptions options = SmallOptions(SyntheticSensor::kRgbd);
  options.threads = 1;
  const std::string dir = TempDir("stopped");
  int polls = 0;
  EXPECT_EQ(WriteSyntheticDataset(dir, options, [&polls] { return ++polls > 3; }), 3);
  const std::unique_ptr<Dataset> dataset = OpenDataset(dir, DatasetOptions());
  EXPECT_EQ(dataset->size(), 3);
  EXPECT_EQ(dataset->GroundTruth().size(), 3u);
  // ... on the loop of the 5 frames asked for, as synthetic.txt says: a 3-frame dataset
  // made with those options is the same frames.
  const std::string description = ReadBytes(fs::path(dir) / "synthetic.txt");
  EXPECT_NE(description.find("frames: 3\n"), std::string::npos) << description;
  EXPECT_NE(description.find("frames_per_loop: 5\n"), std::string::npos) << description;
  SyntheticDatasetOptions three = options;
  three.frames = 3;
  three.frames_per_loop = 5;
  const std::string again = TempDir("stopped_again");
  WriteSyntheticDataset(again, three);
  EXPECT_EQ(ReadBytes(fs::path(again) / "groundtruth.txt"),
            ReadBytes(fs::path(dir) / "groundtruth.txt"));
  EXPECT_EQ(ReadBytes(fs::path(again) / "synthetic.txt"), description);
  fs::remove_all(again);
  // Not stopped: every frame.
  EXPECT_EQ(WriteSyntheticDataset(dir, options, [] { return false; }), options.frames);
  fs::remove_all(dir);
}

// With several workers, a frame past the first unwritten one may be written before the stop
// comes; the dataset ends before that gap and the later images are removed: every image left
// in the directory is listed. Here the second worker stops before its first frame (1) while
// the first writes 0, 2 and 4.
TEST(SyntheticDatasetTest, AStoppedParallelRunLeavesNoUnlistedImage) {
  SyntheticDatasetOptions options = SmallOptions(SyntheticSensor::kRgbd);
  ASSERT_EQ(options.threads, 2);
  const std::string dir = TempDir("stopped_parallel");
  const std::thread::id caller = std::this_thread::get_id();
  EXPECT_EQ(WriteSyntheticDataset(dir, options,
                                  [caller] { return std::this_thread::get_id() != caller; }),
            1);
  const std::unique_ptr<Dataset> dataset = OpenDataset(dir, DatasetOptions());
  EXPECT_EQ(dataset->size(), 1);
  for (const char* folder : {"rgb", "depth"}) {
    const auto files = fs::directory_iterator(fs::path(dir) / folder);
    EXPECT_EQ(std::distance(fs::begin(files), fs::end(files)), 1) << folder;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ieslam
