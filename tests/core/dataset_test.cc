#include "core/dataset.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/imgcodecs.hpp>

#include "core/calibration.h"
#include "core/dataset_formats.h"
#include "core/error.h"
#include "core/trajectory.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

const std::string kTum = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-fr1-desk-9";
const std::string kSevenScenes = std::string(IESLAM_SHARED_DATA_DIR) + "/7scenes-dev";

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Runs `f`, expecting a DataError whose message contains `part`.
template <typename F>
void ExpectDataError(F f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no DataError; expected one mentioning " << part;
  } catch (const DataError& e) {
    EXPECT_TRUE(Contains(e.what(), part)) << "message: " << e.what() << "\nlacks: " << part;
  }
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

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
    const double depth_t = std::stod(fs::path(f.depth_path).stem().string());
    EXPECT_LT(std::fabs(depth_t - f.timestamp), 0.02) << i;
    EXPECT_EQ(std::stod(fs::path(f.colour_path).stem().string()), f.timestamp);
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

// ---------------------------------------------------------------- options, detection, helpers

TEST(DatasetOptions, CheckRejectsBadValuesAndOpenRaisesConfigError) {
  std::string why;
  EXPECT_TRUE(DatasetOptions().Check(&why));
  DatasetOptions bad;
  bad.stride = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_TRUE(Contains(why, "stride"));
  EXPECT_THROW(OpenDataset(kTum, bad), ConfigError);
  bad = DatasetOptions();
  bad.format = "bag";
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_TRUE(Contains(why, "bag"));
  bad = DatasetOptions();
  bad.first = 5;
  bad.last = 4;
  EXPECT_FALSE(bad.Check(&why));
  bad = DatasetOptions();
  bad.max_association_diff_s = std::nan("");
  EXPECT_FALSE(bad.Check(&why));
}

TEST(DatasetFormat, DetectsTumAndSevenScenes) {
  EXPECT_EQ(DetectDatasetFormat(kTum), "tum");
  EXPECT_EQ(DetectDatasetFormat(kSevenScenes + "/"), "7scenes");
}

TEST(DatasetLists, AssociationIsGreedyOnSmallestDifference) {
  // a[1] is closer to b[0] than a[0] is, so a[0] stays unmatched (associate.py's rule).
  auto m = AssociateTimestamps({0.0, 0.012, 0.05}, {0.010, 0.049, 0.2}, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(1, 0));
  EXPECT_EQ(m[1], std::make_pair(2, 1));
  // Each timestamp is used once, and differences must be strictly below the limit.
  m = AssociateTimestamps({1.0, 1.0012}, {1.0005, 1.0212}, 0.02);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0], std::make_pair(0, 0));
}

TEST(DatasetLists, GroundTruthInterpolatesOrTakesNearest) {
  Trajectory gt(2);
  gt[0].timestamp = 1.0;
  gt[1].timestamp = 1.01;
  gt[1].T_w_c = Eigen::Translation3d(0.1, 0, 0) * Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ());
  const auto mid = GroundTruthAt(gt, 1.0025, 0.02);
  ASSERT_TRUE(mid.has_value());
  EXPECT_NEAR(mid->translation().x(), 0.025, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(mid->linear()).angle(), 0.005, 1e-12);
  const auto after = GroundTruthAt(gt, 1.025, 0.02);  // only the last pose is near
  ASSERT_TRUE(after.has_value());
  EXPECT_NEAR(after->translation().x(), 0.1, 1e-12);
  EXPECT_FALSE(GroundTruthAt(gt, 1.05, 0.02).has_value());
  EXPECT_FALSE(GroundTruthAt(gt, 0.9, 0.02).has_value());
}

// ---------------------------------------------------------------- bad input in a temp dir

// A fresh directory per test (temp_directory_path + pid + test name), removed afterwards.
class DatasetFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = (fs::temp_directory_path() /
            ("ieslam_dataset_test_" + std::to_string(::getpid()) + "_" + test->name()))
               .string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  std::string WriteText(const std::string& name, const std::string& text) const {
    fs::create_directories(fs::path(Path(name)).parent_path());
    std::ofstream(Path(name)) << text;
    return Path(name);
  }
  std::string WriteImage(const std::string& name, const cv::Mat& image) const {
    fs::create_directories(fs::path(Path(name)).parent_path());
    EXPECT_TRUE(cv::imwrite(Path(name), image));
    return Path(name);
  }
  static cv::Mat Colour(int w, int h) { return cv::Mat(h, w, CV_8UC3, cv::Scalar(10, 20, 30)); }
  static cv::Mat Depth(int w, int h, uint16_t v) { return cv::Mat(h, w, CV_16UC1, cv::Scalar(v)); }

  // A TUM sequence of `n` 640x480 frames at 30 Hz, depth 5 ms after colour, in dir_/sub.
  void MakeTum(int n, const std::string& sub = ".") const {
    std::string rgb = "# color images\n\n", depth = "# depth maps\n";
    for (int i = 0; i < n; ++i) {
      const std::string t = std::to_string(100.0 + i / 30.0);
      const std::string td = std::to_string(100.005 + i / 30.0);
      const std::string rgb_name = std::string("rgb/").append(t).append(".png");
      const std::string depth_name = std::string("depth/").append(td).append(".png");
      rgb.append(t).append(" ").append(rgb_name).append("\n");
      depth.append(td).append(" ").append(depth_name).append("\n");
      WriteImage(std::string(sub).append("/").append(rgb_name), Colour(640, 480));
      WriteImage(std::string(sub).append("/").append(depth_name), Depth(640, 480, 5000));
    }
    WriteText(sub + "/rgb.txt", rgb);
    WriteText(sub + "/depth.txt", depth);
  }

  // `size` random bytes after `prefix`, over `path`.
  static void WriteGarbage(const std::string& path, const std::string& prefix, int size) {
    std::mt19937 rng(7);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << prefix;
    for (int i = 0; i < size; ++i) out.put(static_cast<char>(rng() & 0xff));
  }

  std::string dir_;
};

DatasetOptions Format(const std::string& format) {
  DatasetOptions options;
  options.format = format;
  return options;
}

TEST_F(DatasetFilesTest, MissingDirectoryOrUnknownLayoutNamesThePath) {
  const std::string missing = Path("no_such_sequence");
  ExpectDataError([&] { OpenDataset(missing, DatasetOptions()); }, missing);
  ExpectDataError([&] { OpenDataset(missing, Format("tum")); }, missing);
  ExpectDataError([&] { DetectDatasetFormat(dir_); }, dir_);  // empty: no known layout
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
  EXPECT_NEAR(dataset->Load(2).depth.at<float>(10, 10), 1.0f, 1e-6);

  // A sequence named after freiburg2 gets fr2's intrinsics.
  const std::string fr2 = Path("rgbd_dataset_freiburg2_xyz");
  MakeTum(1, "rgbd_dataset_freiburg2_xyz");
  dataset = OpenDataset(fr2 + "/", DatasetOptions());
  EXPECT_EQ(dataset->rig().name, "tum_fr2");
  EXPECT_TRUE(Contains(dataset->calibration_source(), "freiburg2"));

  // calib_file wins over the name.
  DatasetOptions options;
  options.calib_file = DefaultCalibrationPath("tum_fr3");
  EXPECT_EQ(OpenDataset(fr2, options)->rig().name, "tum_fr3");

  // A calib.yaml inside the sequence (as `ieslam synth` writes) wins over the name too.
  Rig own = ReadCalibration(DefaultCalibrationPath("tum_fr3"));
  own.name = "own_rig";
  WriteCalibration(fr2 + "/calib.yaml", own);
  dataset = OpenDataset(fr2, DatasetOptions());
  EXPECT_EQ(dataset->rig().name, "own_rig");
  EXPECT_EQ(dataset->calibration_path(), fr2 + "/calib.yaml");
}

TEST_F(DatasetFilesTest, CorruptOrMissingImagesNameTheFileOnLoad) {
  MakeTum(3);
  const auto dataset = OpenDataset(dir_, DatasetOptions());
  // Random bytes under a .png name, and a PNG signature followed by garbage.
  WriteGarbage(dataset->info(0).colour_path, "", 4096);
  WriteGarbage(dataset->info(0).depth_path, "\x89PNG\r\n\x1a\n", 4096);
  ExpectDataError([&] { dataset->Load(0); }, dataset->info(0).colour_path);
  WriteImage(fs::path(dataset->info(0).colour_path).lexically_relative(dir_).string(),
             Colour(640, 480));
  ExpectDataError([&] { dataset->Load(0); }, dataset->info(0).depth_path);
  fs::remove(dataset->info(1).colour_path);
  ExpectDataError([&] { dataset->Load(1); }, dataset->info(1).colour_path);
  EXPECT_NO_THROW(dataset->Load(2));
}

TEST_F(DatasetFilesTest, ImagesOfTheWrongSizeOrTypeNameFileAndSizes) {
  MakeTum(2);
  const auto dataset = OpenDataset(dir_, DatasetOptions());
  const std::string depth0 = dataset->info(0).depth_path;
  WriteImage(fs::path(depth0).lexically_relative(dir_).string(), Depth(320, 240, 5000));
  ExpectDataError([&] { dataset->Load(0); },
                  depth0 + " is 320x240 but calibration 'tum_fr1' expects 640x480");
  const std::string depth1 = dataset->info(1).depth_path;
  WriteImage(fs::path(depth1).lexically_relative(dir_).string(), Colour(640, 480));  // 8-bit
  ExpectDataError([&] { dataset->Load(1); }, depth1);
  const std::string colour1 = dataset->info(1).colour_path;
  WriteImage(fs::path(colour1).lexically_relative(dir_).string(), Colour(641, 480));
  ExpectDataError([&] { dataset->Load(1); }, colour1 + " is 641x480");
}

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

  fs::remove(Path("frame-000001.pose.txt"));
  fs::remove(Path("frame-000001.depth.png"));
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, Path("frame-000001.depth.png"));
}

TEST_F(DatasetFilesTest, PairDatasetReadsTwoCamerasAtTheirOwnSizes) {
  Rig rig = ReadCalibration(DefaultCalibrationPath("sr3000_dragonfly2"));
  rig.name = "small_pair";
  rig.colour.width = 64;
  rig.colour.height = 48;
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

  fs::remove(Path("calib.yaml"));
  ExpectDataError([&] { OpenDataset(dir_, DatasetOptions()); }, Path("calib.yaml"));
}

}  // namespace
}  // namespace ieslam
