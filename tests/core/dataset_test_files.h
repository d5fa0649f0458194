// What the dataset tests share: the real sequences of the shared data directory, checks on
// error messages, and a fixture that writes small datasets into a fresh directory.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/imgcodecs.hpp>

#include "core/dataset.h"
#include "core/error.h"

namespace ieslam {

inline const std::string kTum = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-fr1-desk-9";
inline const std::string kSevenScenes = std::string(IESLAM_SHARED_DATA_DIR) + "/7scenes-dev";

inline bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Runs `f`, expecting an `Error` (DataError, ConfigError) whose message contains `part`.
template <typename Error, typename F>
void ExpectError(F f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one mentioning " << part;
  } catch (const Error& e) {
    EXPECT_TRUE(Contains(e.what(), part)) << "message: " << e.what() << "\nlacks: " << part;
  }
}

template <typename F>
void ExpectDataError(F f, const std::string& part) {
  ExpectError<DataError>(f, part);
}

template <typename F>
void ExpectConfigError(F f, const std::string& part) {
  ExpectError<ConfigError>(f, part);
}

inline std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline DatasetOptions Format(const std::string& format) {
  DatasetOptions options;
  options.format = format;
  return options;
}

// A fresh directory per test (temp_directory_path + pid + test name), removed afterwards.
class DatasetFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = (std::filesystem::temp_directory_path() /
            ("ieslam_dataset_test_" + std::to_string(::getpid()) + "_" + test->name()))
               .string();
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  std::string WriteText(const std::string& name, const std::string& text) const {
    std::filesystem::create_directories(std::filesystem::path(Path(name)).parent_path());
    std::ofstream(Path(name)) << text;
    return Path(name);
  }
  std::string WriteImage(const std::string& name, const cv::Mat& image) const {
    std::filesystem::create_directories(std::filesystem::path(Path(name)).parent_path());
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

}  // namespace ieslam
