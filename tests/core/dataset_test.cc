#include "core/dataset.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/dataset_test_files.h"
#include "core/error.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- options, detection

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

// ---------------------------------------------------------------- bad input in a temp dir

TEST_F(DatasetFilesTest, MissingDirectoryOrUnknownLayoutNamesThePath) {
  const std::string missing = Path("no_such_sequence");
  ExpectDataError([&] { OpenDataset(missing, DatasetOptions()); }, missing);
  ExpectDataError([&] { OpenDataset(missing, Format("tum")); }, missing);
  ExpectDataError([&] { DetectDatasetFormat(dir_); }, dir_);  // empty: no known layout
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

// A cut image decodes (libjpeg fills the rest with grey); Load must refuse it instead.
TEST_F(DatasetFilesTest, TruncatedJpegOrPngIsAnErrorNamingTheFileOnLoad) {
  MakeTum(3);
  const auto dataset = OpenDataset(dir_, DatasetOptions());
  cv::Mat texture(480, 640, CV_8UC3);
  cv::randu(texture, 0, 255);
  std::vector<uchar> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", texture, jpeg));
  const std::string colour0 = dataset->info(0).colour_path;
  std::ofstream(colour0, std::ios::binary)
      .write(reinterpret_cast<const char*>(jpeg.data()), jpeg.size() / 2);
  ASSERT_FALSE(cv::imread(colour0).empty()) << "the decoder alone accepts the cut JPEG";
  ExpectDataError([&] { dataset->Load(0); }, "frame 0: colour image " + colour0 +
                                                 " is truncated: no end-of-image marker FF D9");

  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", Depth(640, 480, 5000), png));
  const std::string depth1 = dataset->info(1).depth_path;
  std::ofstream(depth1, std::ios::binary)
      .write(reinterpret_cast<const char*>(png.data()), png.size() - 1);
  ExpectDataError([&] { dataset->Load(1); }, "frame 1: range image " + depth1 + " is truncated");
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

}  // namespace
}  // namespace ieslam
