#include "core/section_file.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include <unistd.h>

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

constexpr char kMagic[] = "IESLTEST";

class SectionFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = (fs::temp_directory_path() /
             ("ieslam_section_file_test_" + std::to_string(::getpid()) + "_" +
              ::testing::UnitTest::GetInstance()->current_test_info()->name()))
                .string();
  }
  void TearDown() override { fs::remove(path_); }

  void WriteSample() {
    SectionWriter a;
    a.U32(7);
    a.F64(-0.1);
    a.String("hello");
    SectionWriter b;
    b.I64(-5);
    WriteSectionFile(path_, kMagic, 3, {{"AAAA", a.Take()}, {"BBBB", b.Take()}});
  }
  std::string Bytes() const {
    std::ifstream in(path_, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  void SetBytes(const std::string& bytes) const {
    std::ofstream(path_, std::ios::binary | std::ios::trunc) << bytes;
  }
  // The DataError's message of reading the file (empty when it reads).
  std::string ReadError(uint32_t version = 3) const {
    try {
      ReadSectionFile(path_, kMagic, version, "a test file");
    } catch (const DataError& e) {
      return e.what();
    }
    return "";
  }

  std::string path_;
};

TEST_F(SectionFileTest, SectionsReadBackBitForBit) {
  WriteSample();
  const std::vector<FileSection> sections = ReadSectionFile(path_, kMagic, 3, "a test file");
  ASSERT_EQ(sections.size(), 2u);
  EXPECT_EQ(sections[0].tag, "AAAA");
  EXPECT_EQ(sections[1].tag, "BBBB");
  SectionReader a(sections[0].payload, "a");
  EXPECT_EQ(a.U32(), 7u);
  EXPECT_EQ(a.F64(), -0.1);
  EXPECT_EQ(a.String(), "hello");
  a.Finish();
  SectionReader b(sections[1].payload, "b");
  EXPECT_EQ(b.I64(), -5);
  b.Finish();
}

TEST_F(SectionFileTest, EachKindOfBadFileIsNamed) {
  EXPECT_NE(ReadError().find("not found"), std::string::npos) << ReadError();
  WriteSample();
  const std::string good = Bytes();
  EXPECT_EQ(ReadError(), "");
  EXPECT_NE(ReadError(4).find("format version 3, this build reads version 4"), std::string::npos)
      << ReadError(4);

  SetBytes("not a section file at all");
  EXPECT_NE(ReadError().find("not a test file"), std::string::npos) << ReadError();

  SetBytes(good.substr(0, good.size() - 3));
  EXPECT_NE(ReadError().find("truncated in section 'BBBB'"), std::string::npos) << ReadError();
  SetBytes(good.substr(0, 10));
  EXPECT_NE(ReadError().find("truncated"), std::string::npos) << ReadError();

  std::string flipped = good;
  flipped[good.size() - 2] ^= 0x10;  // in BBBB's payload
  SetBytes(flipped);
  EXPECT_NE(ReadError().find("checksum of section 'BBBB'"), std::string::npos) << ReadError();

  std::string version = good;
  version[8] = 9;  // the version, under the header's checksum
  SetBytes(version);
  EXPECT_NE(ReadError().find("header's checksum"), std::string::npos) << ReadError();

  SetBytes(good + "x");
  EXPECT_NE(ReadError().find("1 bytes after the last section"), std::string::npos) << ReadError();

  EXPECT_NE(ReadError().find(path_), std::string::npos);
}

TEST(SectionReaderTest, ReadsPastTheEndAndHugeCountsAreErrorsNamingThePayload) {
  SectionWriter w;
  w.U64(std::numeric_limits<uint64_t>::max());  // a count no payload can hold
  w.U8(1);
  const std::string payload = w.Take();
  SectionReader r(payload, "file: section 'X'");
  try {
    r.Count(8);
    FAIL() << "a huge count was taken";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("file: section 'X': a count of"), std::string::npos);
  }
  SectionReader short_read(payload, "file: section 'X'");
  short_read.U64();
  short_read.U8();
  EXPECT_THROW(short_read.U8(), DataError);
  SectionReader left_over(payload, "file: section 'X'");
  left_over.U64();
  EXPECT_THROW(left_over.Finish(), DataError);
}

}  // namespace
}  // namespace ieslam
