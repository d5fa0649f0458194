#include "core/image_file.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/imgcodecs.hpp>

#include "core/dataset_test_files.h"
#include "core/error.h"

namespace ieslam {
namespace {

// A textured image, so that the encoded files have many data bytes to cut.
cv::Mat Pattern(int type) {
  cv::Mat image(48, 64, type);
  cv::randu(image, 0, type == CV_16UC1 ? 60000 : 255);
  return image;
}

std::string Encode(const std::string& ext, const cv::Mat& image) {
  std::vector<uchar> buffer;
  EXPECT_TRUE(cv::imencode(ext, image, buffer)) << ext;
  return std::string(buffer.begin(), buffer.end());
}

TEST(ImageFileDefect, WholeFilesPass) {
  EXPECT_EQ(ImageFileDefect(Encode(".jpg", Pattern(CV_8UC3))), "");
  EXPECT_EQ(ImageFileDefect(Encode(".png", Pattern(CV_8UC3))), "");
  EXPECT_EQ(ImageFileDefect(Encode(".png", Pattern(CV_16UC1))), "");
  EXPECT_EQ(ImageFileDefect(Encode(".ppm", Pattern(CV_8UC3))), "");
  EXPECT_EQ(ImageFileDefect(Encode(".pgm", Pattern(CV_16UC1))), "");
  EXPECT_EQ(ImageFileDefect(Encode(".bmp", Pattern(CV_8UC3))), "");
  // Padding after the end marker, and bytes after IEND, are not a truncation.
  EXPECT_EQ(ImageFileDefect(Encode(".jpg", Pattern(CV_8UC3)) + std::string(7, '\0')), "");
  EXPECT_EQ(ImageFileDefect(Encode(".jpg", Pattern(CV_8UC3)) + "\r\n"), "");
  // A trailer after the image (vendor data, a second MPO frame's header).
  EXPECT_EQ(ImageFileDefect(Encode(".jpg", Pattern(CV_8UC3)) + "\xff\xd8\xff\xe1trailer"), "");
  EXPECT_EQ(ImageFileDefect(Encode(".png", Pattern(CV_8UC3)) + "trailer"), "");
  // Not an image format with a check: left to the decoder.
  EXPECT_EQ(ImageFileDefect("not an image"), "");
}

TEST(ImageFileDefect, EveryCutOfACheckedFormatIsCaught) {
  for (const auto& [ext, type] : std::vector<std::pair<std::string, int>>{{".jpg", CV_8UC3},
                                                                          {".png", CV_8UC3},
                                                                          {".png", CV_16UC1},
                                                                          {".ppm", CV_8UC3},
                                                                          {".pgm", CV_16UC1},
                                                                          {".bmp", CV_8UC3}}) {
    const std::string whole = Encode(ext, Pattern(type));
    // Every length from the longest signature (PNG's 8 bytes) to one byte short.
    for (size_t length = 8; length < whole.size(); ++length) {
      const std::string reason = ImageFileDefect(whole.substr(0, length));
      // A cut PGM/PPM header that no longer parses is left to the decoder.
      if (reason.empty() && (ext == ".ppm" || ext == ".pgm") && length < 20) continue;
      ASSERT_FALSE(reason.empty()) << ext << " cut to " << length << " of " << whole.size();
    }
  }
  EXPECT_TRUE(Contains(ImageFileDefect(Encode(".jpg", Pattern(CV_8UC3)).substr(0, 500)), "FF D9"));
  EXPECT_TRUE(Contains(ImageFileDefect(Encode(".png", Pattern(CV_8UC3)).substr(0, 500)), "IDAT"));
}

// libpng fails on a damaged IDAT with a line of its own on stderr; the CRC catches it first.
TEST(ImageFileDefect, ACriticalPngChunkWithABadCrcIsDamaged) {
  std::string png = Encode(".png", Pattern(CV_8UC3));
  const size_t idat = png.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  png[idat + 20] = static_cast<char>(png[idat + 20] ^ 0x55);
  EXPECT_TRUE(Contains(ImageFileDefect(png), "damaged: the CRC of PNG chunk 'IDAT'"))
      << ImageFileDefect(png);
}

class ImageFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("ieslam_image_file_test_" + std::to_string(::getpid()) + "_" + test->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Write(const std::string& name, const std::string& bytes) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  std::filesystem::path dir_;
};

TEST_F(ImageFileTest, ReadsWholeFilesAsImread) {
  const cv::Mat colour = Pattern(CV_8UC3);
  const std::string png = Write("c.png", Encode(".png", colour));
  const cv::Mat read = ReadImageFile(png, cv::IMREAD_COLOR);
  EXPECT_EQ(cv::countNonZero(read.reshape(1) != cv::imread(png, cv::IMREAD_COLOR).reshape(1)), 0);
  const std::string depth = Write("d.png", Encode(".png", Pattern(CV_16UC1)));
  EXPECT_EQ(ReadImageFile(depth, cv::IMREAD_UNCHANGED).type(), CV_16UC1);
  const std::string jpg = Write("c.jpg", Encode(".jpg", colour));
  EXPECT_EQ(cv::countNonZero(ReadImageFile(jpg, cv::IMREAD_COLOR).reshape(1) !=
                             cv::imread(jpg, cv::IMREAD_COLOR).reshape(1)),
            0);
}

TEST_F(ImageFileTest, TruncatedJpegAndPngAreErrorsNamingTheFile) {
  // libjpeg decodes a cut JPEG into an image grey below the cut; it must not get that far.
  const std::string jpeg = Encode(".jpg", Pattern(CV_8UC3));
  const std::string cut_jpeg = Write("cut.jpg", jpeg.substr(0, jpeg.size() * 2 / 3));
  ASSERT_FALSE(cv::imread(cut_jpeg).empty()) << "the decoder alone would accept it";
  ExpectDataError([&] { ReadImageFile(cut_jpeg, cv::IMREAD_COLOR, "colour image"); },
                  "colour image " + cut_jpeg + " is truncated");
  const std::string png = Encode(".png", Pattern(CV_16UC1));
  const std::string cut_png = Write("cut.png", png.substr(0, png.size() - 12));  // no IEND
  ExpectDataError([&] { ReadImageFile(cut_png, cv::IMREAD_UNCHANGED, "range image"); },
                  "range image " + cut_png + " is truncated");
}

TEST_F(ImageFileTest, EmptyGarbageAndMissingFilesAreErrorsNamingTheFile) {
  const std::string empty = Write("empty.png", "");
  ExpectDataError([&] { ReadImageFile(empty, cv::IMREAD_COLOR); }, "cannot decode image " + empty);
  const std::string garbage = Write("garbage.png", "not an image at all");
  ExpectDataError([&] { ReadImageFile(garbage, cv::IMREAD_COLOR); }, garbage);
  const std::string missing = (dir_ / "missing.png").string();
  ExpectDataError([&] { ReadImageFile(missing, cv::IMREAD_COLOR); }, "image not found: " + missing);
}

}  // namespace
}  // namespace ieslam
