#include "core/data_directory.h"

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/calibration.h"
#include "core/dataset_test_files.h"
#include "core/error.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

TEST(DataDirectoryCandidates, EnvironmentAloneElseInstallBesideTheExecutableThenSourceTree) {
  const std::vector<std::string> alone = DataDirectoryCandidates(nullptr, "");
  ASSERT_EQ(alone.size(), 1u);
  EXPECT_EQ(alone[0], std::string(IESLAM_SOURCE_DIR) + "/data");
  EXPECT_EQ(DataDirectoryCandidates("", ""), alone);  // an empty variable is no variable

  // A directory the user names is the only place: a wrong one is an error, not a fallback.
  EXPECT_EQ(DataDirectoryCandidates("/opt/data", "/usr/bin/ieslam"),
            std::vector<std::string>{"/opt/data"});
  const std::vector<std::string> all = DataDirectoryCandidates(nullptr, "/usr/bin/ieslam");
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0], "/usr/share/ieslam");
  EXPECT_EQ(all[1], alone[0]);
}

// A fake install tree under a fresh directory: prefix/bin, prefix/share/ieslam/calib.
class DataDirectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::temp_directory_path() /
            ("ieslam_data_directory_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(root_);
    fs::create_directories(root_ / "prefix/bin");
    fs::create_directories(root_ / "prefix/share/ieslam/calib");
    fs::create_directories(root_ / "empty");
    fs::copy_file(std::string(IESLAM_SOURCE_DIR) + "/data/calib/tum_fr1.yaml",
                  root_ / "prefix/share/ieslam/calib/tum_fr1.yaml");
  }
  void TearDown() override {
    SetDataDirectoryCandidates(DataDirectoryCandidates(nullptr, ""));
    fs::remove_all(root_);
  }
  fs::path root_;
};

TEST_F(DataDirectoryTest, TheFirstPlaceWithCalibWins) {
  const std::string empty = (root_ / "empty").string();
  const std::string installed = (root_ / "prefix/share/ieslam").string();
  const std::string executable = (root_ / "prefix/bin/ieslam").string();
  EXPECT_EQ(FindDataDirectory(DataDirectoryCandidates(nullptr, executable)), installed);
  EXPECT_EQ(FindDataDirectory({empty, installed}), installed);
  // The source tree's data/ is the last resort.
  EXPECT_EQ(FindDataDirectory(DataDirectoryCandidates(nullptr, "")),
            std::string(IESLAM_SOURCE_DIR) + "/data");
  // A named directory without calib/ is an error naming it.
  ExpectConfigError([&] { FindDataDirectory(DataDirectoryCandidates(empty.c_str(), executable)); },
                    "looked in: " + empty);

  SetDataDirectoryCandidates(DataDirectoryCandidates(nullptr, executable));
  EXPECT_EQ(DefaultCalibrationPath("tum_fr1"), installed + "/calib/tum_fr1.yaml");
  EXPECT_EQ(ReadCalibration(DefaultCalibrationPath("tum_fr1")).name, "tum_fr1");
}

TEST_F(DataDirectoryTest, NothingFoundNamesEveryPlaceTried) {
  const std::string empty = (root_ / "empty").string();
  const std::string missing = (root_ / "missing").string();
  ExpectConfigError(
      [&] {
        FindDataDirectory({empty, missing});
      },
      "looked in: " + empty + ", " + missing);
  SetDataDirectoryCandidates({missing});
  ExpectConfigError([&] { DefaultCalibrationPath("tum_fr1"); }, "IESLAM_DATA_DIR");
}

}  // namespace
}  // namespace ieslam
