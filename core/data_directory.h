// Where the data shipped with ieslam (calib/, config/) is found at run time: the source tree's
// data/ for a build, <prefix>/share/ieslam after `cmake --install`, or a directory the user
// names with the environment variable IESLAM_DATA_DIR.
#pragma once

#include <string>
#include <vector>

namespace ieslam {

// The places to search, in order: `env_value` ($IESLAM_DATA_DIR) when non-null and non-empty
// (then the only place: a user who names a data directory is told when it is wrong, rather
// than served another one); else the installed layout relative to `executable` (<exe
// dir>/../share/ieslam for the default install directories) when `executable` is non-empty,
// and the source tree's data/ compiled in.
std::vector<std::string> DataDirectoryCandidates(const char* env_value,
                                                 const std::string& executable);

// The first of `candidates` that holds a calib/ directory. Throws ConfigError naming every
// place tried.
std::string FindDataDirectory(const std::vector<std::string>& candidates);

// The places DataDirectory() searches. A program sets them once, before it opens a dataset
// (the library cannot know the executable's path or read the environment behind its caller's
// back); until then they are the source tree's data/ alone, as for library users and tests.
void SetDataDirectoryCandidates(std::vector<std::string> candidates);
const std::vector<std::string>& SearchedDataDirectories();

// FindDataDirectory(SearchedDataDirectories()).
std::string DataDirectory();

}  // namespace ieslam
