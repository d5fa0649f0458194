// `ieslam localize` as a user runs it: a run's map, then the same real frames (tum-fr1-desk-9)
// placed in it; and the bad maps a user can hand it.
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "command_test_util.h"
#include "core/calibration.h"
#include "core/dataset.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;
using testing_apps::ReadFile;
using testing_apps::RunIeslam;

const std::string kDesk = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-fr1-desk-9";

class CommandLocalizeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ =
        fs::temp_directory_path() / ("ieslam_command_localize_test_" + std::to_string(::getpid()));
    const testing_apps::CommandResult run =
        RunIeslam("run --dataset " + kDesk + " --output " + (root_ / "run").string() +
                  " --threads 1 --quiet");
    ASSERT_EQ(run.exit_code, 0) << run.output;
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }
  static std::string Localize(const std::string& map, const std::string& output,
                              const std::string& extra = "") {
    return "localize --map " + map + " --dataset " + kDesk + " --output " +
           (root_ / output).string() + " --threads 1 --quiet " + extra;
  }
  static fs::path root_;
};
fs::path CommandLocalizeTest::root_;

TEST_F(CommandLocalizeTest, PlacesTheMappedFramesAndWritesEveryFileTheSameTwice) {
  const testing_apps::CommandResult a = RunIeslam(Localize((root_ / "run").string(), "a"));
  ASSERT_EQ(a.exit_code, 0) << a.output;
  EXPECT_NE(a.output.find("9 of 9 frames localised"), std::string::npos) << a.output;
  EXPECT_NE(a.output.find("ATE RMSE in the map frame"), std::string::npos) << a.output;
  // The map directory itself works as well as the run's.
  const testing_apps::CommandResult b = RunIeslam(Localize((root_ / "run" / "map").string(), "b"));
  ASSERT_EQ(b.exit_code, 0) << b.output;
  for (const char* name : {"trajectory.tum", "covariances.txt", "frames.txt", "groundtruth.tum"}) {
    const std::string text = ReadFile(root_ / "a" / name);
    EXPECT_FALSE(text.empty()) << name;
    EXPECT_EQ(text, ReadFile(root_ / "b" / name)) << name << " differs between two runs";
  }
  const std::string report = ReadFile(root_ / "a" / "report.json");
  for (const char* key : {"\"frames_localized\": 9", "\"localized_share\": 1.0", "\"map_frame\"",
                          "\"consistency\"", "\"real_time_factor\"", "\"load_map\""}) {
    EXPECT_NE(report.find(key), std::string::npos) << key << " in\n" << report;
  }
  // Each mapped frame lies on its own keyframe pose in the map within a few millimetres: the
  // trajectory is in the map's frame, not re-aligned.
  std::ifstream keyframes(root_ / "run" / "keyframes.tum"), placed(root_ / "a" / "trajectory.tum");
  std::string line;
  ASSERT_TRUE(std::getline(keyframes, line) && std::getline(placed, line));  // the headers
  double t0 = 0, x0 = 0, t1 = 0, x1 = 0;
  ASSERT_TRUE(keyframes >> t0 >> x0) << "no keyframe line";
  ASSERT_TRUE(placed >> t1 >> x1) << "no placed frame line";
  EXPECT_EQ(t0, t1);
  EXPECT_NEAR(x0, x1, 0.005);
}

TEST_F(CommandLocalizeTest, AMissingOrTruncatedMapIsExit3NamingTheFile) {
  const testing_apps::CommandResult missing =
      RunIeslam(Localize((root_ / "nothing").string(), "missing"));
  EXPECT_EQ(missing.exit_code, 3) << missing.output;
  EXPECT_NE(missing.output.find((root_ / "nothing" / "map.bin").string()), std::string::npos)
      << missing.output;

  fs::create_directories(root_ / "cut");
  const std::string bytes = ReadFile(root_ / "run" / "map" / "map.bin");
  std::ofstream((root_ / "cut" / "map.bin").string(), std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  const testing_apps::CommandResult cut = RunIeslam(Localize((root_ / "cut").string(), "cut_out"));
  EXPECT_EQ(cut.exit_code, 3) << cut.output;
  EXPECT_NE(cut.output.find("truncated"), std::string::npos) << cut.output;
  EXPECT_FALSE(fs::exists(root_ / "cut_out" / "report.json"));
}

TEST_F(CommandLocalizeTest, AMapOfAnotherCalibrationIsExit3SayingSo) {
  Rig rig = OpenDataset(kDesk, DatasetOptions())->rig();
  rig.colour.fx *= 1.1;
  WriteCalibration((root_ / "other.yaml").string(), rig);
  const testing_apps::CommandResult other = RunIeslam(
      Localize((root_ / "run").string(), "other", "--calib " + (root_ / "other.yaml").string()));
  EXPECT_EQ(other.exit_code, 3) << other.output;
  EXPECT_NE(other.output.find("another calibration"), std::string::npos) << other.output;
  EXPECT_FALSE(fs::exists(root_ / "other" / "report.json"));
}

}  // namespace
}  // namespace ieslam
