#include "core/stamped_list.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/file_util.h"
#include "core/input_file.h"

namespace ieslam {

std::vector<StampedPath> ReadStampedList(const std::string& list_path) {
  RequireRegularInputFile(list_path, "image list", kMaxListFileBytes);
  std::ifstream in(list_path);
  if (!in) throw DataError("cannot open image list " + list_path);
  return ParseStampedList(in, list_path, std::filesystem::path(list_path).parent_path().string());
}

std::vector<StampedPath> ParseStampedList(std::istream& in, const std::string& list_path,
                                          const std::string& directory) {
  std::vector<StampedPath> entries;
  std::string line;
  int line_number = 0;
  // Messages name the file and line, as compilers do: "rgb.txt:12: ...".
  const auto fail = [&](const std::string& problem) {
    throw DataError(list_path + ":" + std::to_string(line_number) + ": " + problem);
  };
  while (std::getline(in, line)) {
    ++line_number;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::string stamp, path;
    if (!(fields >> stamp >> path)) {
      fail("expected `timestamp path`, got: " + line);
    }
    char* end = nullptr;
    const double t = std::strtod(stamp.c_str(), &end);
    if (end == stamp.c_str() || *end != '\0' || !std::isfinite(t)) {
      fail("not a finite timestamp: " + stamp);
    }
    if (!entries.empty() && !(t > entries.back().timestamp)) {
      const StampedPath& previous = entries.back();
      std::ostringstream s;
      s.precision(6);
      if (t == previous.timestamp) {
        s << "duplicate timestamp " << stamp << " (also on line " << previous.line << ")";
      } else {
        s << std::fixed << "timestamps must increase strictly, got " << t << " after "
          << previous.timestamp << " on line " << previous.line;
      }
      fail(s.str());
    }
    entries.push_back({t, ResolvePath(directory, path), line_number});
  }
  return entries;
}

}  // namespace ieslam
