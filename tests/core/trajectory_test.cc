#include "core/trajectory.h"

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/file_util.h"
#include "core/pose.h"

namespace ieslam {
namespace {

class TrajectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("ieslam_trajectory_test_" +
            std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Write(const std::string& name, const std::string& content) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << content;
    return path;
  }
  std::filesystem::path dir_;
};

TEST_F(TrajectoryTest, WriteThenReadRoundTrips) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> value(-3.0, 3.0);
  Trajectory trajectory;
  for (int i = 0; i < 20; ++i) {
    Vector6d pose;
    for (int k = 0; k < 6; ++k) pose[k] = value(rng);
    pose[4] *= 0.4;
    trajectory.push_back({1305031102.175304 + i / 30.0, PoseToIsometry(pose)});
  }
  const std::string path = (dir_ / "t.tum").string();
  WriteTumTrajectory(path, trajectory, "ieslam test");
  const Trajectory back = ReadTumTrajectory(path);
  ASSERT_EQ(back.size(), trajectory.size());
  for (size_t i = 0; i < back.size(); ++i) {
    EXPECT_NEAR(back[i].timestamp, trajectory[i].timestamp, 1e-6);
    EXPECT_LT((back[i].T_w_c.matrix() - trajectory[i].T_w_c.matrix()).norm(), 1e-8);
  }
  // No temporary file is left behind.
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir_)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
}

TEST_F(TrajectoryTest, ReadsCommentsBlankLinesAndNormalisesQuaternions) {
  const std::string path = Write("gt.txt",
                                 "# ground truth trajectory\n"
                                 "# timestamp tx ty tz qx qy qz qw\n"
                                 "\n"
                                 "1.0 0 0 0 0 0 0 1.0001\n"
                                 "2.0 1 2 3 0 0 0.7071 0.7071\n");
  const Trajectory trajectory = ReadTumTrajectory(path);
  ASSERT_EQ(trajectory.size(), 2u);
  EXPECT_LT((trajectory[0].T_w_c.linear() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(trajectory[1].T_w_c.linear().determinant(), 1.0, 1e-12);
  EXPECT_EQ(trajectory[1].T_w_c.translation(), Eigen::Vector3d(1, 2, 3));
}

void ExpectDataError(const std::string& path, const std::string& needle) {
  try {
    ReadTumTrajectory(path);
    FAIL() << "expected DataError for " << path;
  } catch (const DataError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}

TEST_F(TrajectoryTest, BadFilesNameTheFileAndLine) {
  ExpectDataError((dir_ / "missing.txt").string(), "not found");
  ExpectDataError(Write("short.txt", "1.0 0 0 0 0 0 1\n"), ":1");
  ExpectDataError(Write("nan.txt", "1.0 0 0 0 0 0 0 1\n2.0 nan 0 0 0 0 0 1\n"), ":2");
  ExpectDataError(Write("inf.txt", "1.0 0 0 inf 0 0 0 1\n"), "non-finite");
  ExpectDataError(Write("text.txt", "1.0 0 zero 0 0 0 0 1\n"), "zero");
  ExpectDataError(Write("zeroq.txt", "1.0 0 0 0 0 0 0 0\n"), "quaternion");
  ExpectDataError(Write("unsorted.txt", "2.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n"), "increase");
  ExpectDataError(Write("dup.txt", "1.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n"), "increase");
}

TEST_F(TrajectoryTest, FormatsSixDecimalTimestampsAndPositiveW) {
  TimedPose pose;
  pose.timestamp = 12.3456789;
  pose.T_w_c.linear() = Eigen::AngleAxisd(3.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const std::string line = FormatTumLine(pose);
  EXPECT_EQ(line.substr(0, 10), "12.345679 ");
  std::istringstream fields(line);
  double v[8];
  for (double& x : v) fields >> x;
  EXPECT_GE(v[7], 0.0);
}

TEST_F(TrajectoryTest, AtomicWriteFailsCleanlyInAMissingDirectory) {
  EXPECT_THROW(WriteTextAtomically((dir_ / "no" / "such" / "file.txt").string(), "x"), OutputError);
}

// Found by tests/fuzz/tum_trajectory_fuzz.cc: a huge but finite coordinate was cut off by a
// fixed-size line buffer, so the written file did not read back.
TEST_F(TrajectoryTest, HugeValuesAreWrittenWholeAndReadBack) {
  TimedPose pose;
  pose.timestamp = 1305031449.8096;
  pose.T_w_c.translation() = Eigen::Vector3d(1.2334, -1.111e308, 1.6939);
  const std::string line = FormatTumLine(pose);
  EXPECT_GT(line.size(), 300u);
  const TimedPose back = ParseTumPoseLine(line, "written");
  EXPECT_EQ(back.T_w_c.translation().y(), -1.111e308);
  EXPECT_EQ(back.T_w_c.translation().z(), 1.6939);
  EXPECT_EQ(back.timestamp, 1305031449.8096);
}

// Between two samples: the translation on the line, the rotation on the geodesic; a stamp on a
// sample is that sample; outside or across a gap: nothing.
TEST(InterpolatePoseTest, SlerpsBetweenSamplesAndRefusesGapsAndTheOutside) {
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = Eigen::Isometry3d::Identity();
  b.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  b.translation() = Eigen::Vector3d(1.0, -2.0, 0.5);
  const Trajectory trajectory = {{1.0, a}, {1.02, b}, {2.0, a}};
  const std::optional<Eigen::Isometry3d> quarter = InterpolatePose(trajectory, 1.005, 0.05);
  ASSERT_TRUE(quarter.has_value());
  EXPECT_LT((quarter->translation() - Eigen::Vector3d(0.25, -0.5, 0.125)).norm(), 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(quarter->linear()).angle(), 0.1, 1e-12);
  EXPECT_TRUE(InterpolatePose(trajectory, 1.02, 0.0)->isApprox(b));
  EXPECT_TRUE(InterpolatePose(trajectory, 2.0, 0.0)->isApprox(a));
  EXPECT_FALSE(InterpolatePose(trajectory, 1.5, 0.05).has_value());  // 0.98 s without samples
  EXPECT_TRUE(InterpolatePose(trajectory, 1.5, 1.0).has_value());
  EXPECT_FALSE(InterpolatePose(trajectory, 0.99, 1.0).has_value());
  EXPECT_FALSE(InterpolatePose(trajectory, 2.01, 1.0).has_value());
  EXPECT_FALSE(InterpolatePose({}, 1.0, 1.0).has_value());
}

}  // namespace
}  // namespace ieslam
