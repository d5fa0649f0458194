#include "core/input_file.h"

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

// A directory of its own per test (ctest runs the tests in parallel). A call that blocks on
// the FIFO is ended by SIGALRM, so a regression fails instead of stalling the suite.
class InputFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    alarm(20);
    dir_ = fs::temp_directory_path() /
           ("ieslam_input_file_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override {
    fs::remove_all(dir_);
    alarm(0);
  }

  // The DataError message ReadInputFile throws ("" when it reads the file).
  static std::string ReadError(const std::string& path, std::uintmax_t max_bytes = 1000) {
    try {
      ReadInputFile(path, "calibration file", max_bytes);
    } catch (const DataError& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
};

TEST_F(InputFileTest, ReadsARegularFileWhole) {
  const std::string content("a: 1\n\0b\n", 8);
  std::ofstream(dir_ / "c.yaml", std::ios::binary) << content;
  EXPECT_EQ(ReadInputFile((dir_ / "c.yaml").string(), "calibration file", 8), content);
  EXPECT_NO_THROW(RequireRegularInputFile((dir_ / "c.yaml").string(), "image", 8));
}

TEST_F(InputFileTest, FifoIsRefusedWithoutBlocking) {
  const std::string fifo = (dir_ / "fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_EQ(ReadError(fifo), "calibration file is not a regular file: " + fifo);
  EXPECT_THROW(RequireRegularInputFile(fifo, "depth image"), DataError);
}

TEST_F(InputFileTest, DevicesAndDirectoriesAreRefused) {
  EXPECT_EQ(ReadError("/dev/zero"), "calibration file is not a regular file: /dev/zero");
  EXPECT_EQ(ReadError("/dev/urandom"), "calibration file is not a regular file: /dev/urandom");
  EXPECT_EQ(ReadError(dir_.string()), "calibration file is not a regular file: " + dir_.string());
  const fs::path link = dir_ / "link";
  fs::create_symlink("/dev/zero", link);  // followed, then refused
  EXPECT_EQ(ReadError(link.string()), "calibration file is not a regular file: " + link.string());
}

TEST_F(InputFileTest, MissingAndOversizedFilesAreRefusedNamingThem) {
  const std::string missing = (dir_ / "none.yaml").string();
  EXPECT_EQ(ReadError(missing), "calibration file not found: " + missing);
  EXPECT_EQ(ReadError((dir_ / "none" / "x.yaml").string()),
            "calibration file not found: " + (dir_ / "none" / "x.yaml").string());
  const std::string big = (dir_ / "big.yaml").string();
  std::ofstream(big) << std::string(1001, 'x');
  EXPECT_EQ(ReadError(big), "calibration file is 1001 bytes, more than the 1000 allowed: " + big);
  EXPECT_EQ(ReadError(big, 1001), "");
  try {
    RequireRegularInputFile(big, "trajectory file", 10);
    FAIL() << "accepted";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()),
              "trajectory file is 1001 bytes, more than the 10 allowed: " + big);
  }
}

}  // namespace
}  // namespace ieslam
