#include "core/file_util.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

TEST(FileUtil, JoinAndResolvePaths) {
  // A relative path resolves as it joins; an absolute one stays itself.
  for (const std::string dir : {"a", "a/", ""}) {
    const std::string expected = dir.empty() ? "b.txt" : "a/b.txt";
    EXPECT_EQ(JoinPath(dir, "b.txt"), expected) << dir;
    EXPECT_EQ(ResolvePath(dir, "b.txt"), expected) << dir;
    EXPECT_EQ(ResolvePath(dir, "/elsewhere/1.png"), "/elsewhere/1.png") << dir;
  }
}

TEST(FileUtil, AtomicWriteReplacesTheFileAndRequireFileNamesIt) {
  const std::string path = ::testing::TempDir() + "/ieslam_file_util_test.txt";
  WriteTextAtomically(path, "first");
  WriteTextAtomically(path, "second");
  std::ifstream in(path);
  std::string content;
  std::getline(in, content);
  EXPECT_EQ(content, "second");
  EXPECT_NO_THROW(RequireFile(path, "text"));
  std::filesystem::remove(path);
  try {
    RequireFile(path, "text");
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()), "text not found: " + path);
  }
}

}  // namespace
}  // namespace ieslam
