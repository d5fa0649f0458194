// TUM-style `timestamp path` lists, the image lists of the tum and pair dataset formats
// (rgb.txt, depth.txt, colour.txt, range.txt): one entry per line, `#` comments and blank
// lines skipped, timestamps strictly increasing.
#pragma once

#include <istream>
#include <string>
#include <vector>

namespace ieslam {

// One entry of a TUM-style `timestamp path` list.
struct StampedPath {
  double timestamp = 0.0;
  std::string path;  // resolved against the list's directory
  int line = 0;      // 1-based line in the list, for messages
};

// Reads a `timestamp path` list (`#` comments and blank lines skipped). Throws DataError
// naming the file and line for a missing file, a malformed line, a non-finite timestamp,
// or timestamps that are not strictly increasing (unsorted or duplicate).
std::vector<StampedPath> ReadStampedList(const std::string& list_path);
// The same from a stream; `list_path` names it in messages, paths resolve against `directory`.
std::vector<StampedPath> ParseStampedList(std::istream& in, const std::string& list_path,
                                          const std::string& directory);

}  // namespace ieslam
