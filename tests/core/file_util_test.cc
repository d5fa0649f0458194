#include "core/file_util.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

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

// What a signal handler ending the process calls: the write in progress leaves no temp file.
TEST(FileUtil, TheTempFileOfAWriteInProgressCanBeRemoved) {
  const std::string path = ::testing::TempDir() + "/ieslam_file_util_test_in_progress_" +
                           std::to_string(::getpid()) + ".txt";
  const std::string temp = path + ".tmp." + std::to_string(::getpid());
  bool existed = false, removed = false;
  EXPECT_THROW(WriteFileAtomically(path,
                                   [&](std::ostream& out) {
                                     out << "partial";
                                     existed = std::filesystem::exists(temp);
                                     RemoveTempFilesInProgress();
                                     removed = !std::filesystem::exists(temp);
                                   }),
               OutputError);  // its rename finds no temp file
  EXPECT_TRUE(existed);
  EXPECT_TRUE(removed);
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(FileUtil, AnUnwritableDirectoryIsAnOutputError) {
  EXPECT_THROW(WriteTextAtomically("/nonexistent_ieslam_dir/x.txt", "x"), OutputError);
}

}  // namespace
}  // namespace ieslam
