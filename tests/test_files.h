// Reading back the files a test made.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace ieslam {
namespace testing_files {

// The whole file, bytes as they are ("" when it cannot be read).
inline std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace testing_files
}  // namespace ieslam
