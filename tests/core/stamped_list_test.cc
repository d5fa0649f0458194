#include "core/stamped_list.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "core/dataset_test_files.h"
#include "core/error.h"

namespace ieslam {
namespace {

std::vector<StampedPath> Parse(const std::string& text) {
  std::istringstream in(text);
  return ParseStampedList(in, "list.txt", "/data");
}

TEST(StampedList, SkipsCommentsAndResolvesPathsAgainstTheDirectory) {
  const auto entries = Parse("# header\n\n  \t\n1.5 rgb/a.png\n2.25 /abs/b.png extra\n");
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_EQ(entries[0].timestamp, 1.5);
  EXPECT_EQ(entries[0].path, "/data/rgb/a.png");
  EXPECT_EQ(entries[0].line, 4);
  EXPECT_EQ(entries[1].path, "/abs/b.png");
  EXPECT_EQ(entries[1].line, 5);
}

TEST(StampedList, BadLinesNameTheListAndTheLine) {
  ExpectDataError([] { Parse("1.0 a.png\n0.5 b.png\n"); }, "list.txt:2: timestamps must increase");
  ExpectDataError([] { Parse("1.0 a.png\n1.0 b.png\n"); }, "list.txt:2: duplicate timestamp");
  ExpectDataError([] { Parse("# c\nnan a.png\n"); }, "list.txt:2: not a finite timestamp");
  ExpectDataError([] { Parse("1.0x a.png\n"); }, "list.txt:1: not a finite timestamp");
  ExpectDataError([] { Parse("1.0\n"); }, "list.txt:1: expected `timestamp path`");
}

TEST_F(DatasetFilesTest, StampedListFromAFileResolvesAgainstItsDirectory) {
  WriteText("sub/rgb.txt", "3.0 rgb/c.png\n");
  const auto entries = ReadStampedList(Path("sub/rgb.txt"));
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].path, Path("sub/rgb/c.png"));
  ExpectDataError([&] { ReadStampedList(Path("missing.txt")); }, Path("missing.txt"));
}

}  // namespace
}  // namespace ieslam
