#include "core/data_directory.h"

#include <filesystem>
#include <utility>

#include "core/error.h"

namespace ieslam {
namespace {

// Set from main() before any thread starts and read-only afterwards.
std::vector<std::string>& Candidates() {
  static std::vector<std::string> candidates = {IESLAM_SOURCE_DATA_DIR};
  return candidates;
}

}  // namespace

std::vector<std::string> DataDirectoryCandidates(const char* env_value,
                                                 const std::string& executable) {
  if (env_value != nullptr && *env_value != '\0') return {env_value};
  std::vector<std::string> candidates;
  if (!executable.empty()) {
    // IESLAM_DATA_DIR_FROM_BIN: the install's data directory relative to its bin directory.
    const std::filesystem::path bin = std::filesystem::path(executable).parent_path();
    candidates.push_back((bin / IESLAM_DATA_DIR_FROM_BIN).lexically_normal().string());
  }
  candidates.emplace_back(IESLAM_SOURCE_DATA_DIR);
  return candidates;
}

std::string FindDataDirectory(const std::vector<std::string>& candidates) {
  std::string tried;
  for (const std::string& candidate : candidates) {
    std::error_code ec;
    if (std::filesystem::is_directory(std::filesystem::path(candidate) / "calib", ec)) {
      return candidate;
    }
    tried += (tried.empty() ? "" : ", ") + candidate;
  }
  throw ConfigError("no ieslam data directory (one holding calib/) found; looked in: " +
                    (tried.empty() ? std::string("nowhere") : tried) +
                    "; set IESLAM_DATA_DIR to one, or give a calibration file");
}

void SetDataDirectoryCandidates(std::vector<std::string> candidates) {
  Candidates() = std::move(candidates);
}

const std::vector<std::string>& SearchedDataDirectories() { return Candidates(); }

std::string DataDirectory() { return FindDataDirectory(Candidates()); }

}  // namespace ieslam
