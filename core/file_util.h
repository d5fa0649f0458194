// Small file helpers shared by every stage: atomic writes, existence checks and paths.
#pragma once

#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace ieslam {

// Writes a file so that readers never see it half-written: the content goes to a
// temporary file in the same directory, which is then renamed over `path`.
// Throws OutputError naming the path when the directory cannot be written.
void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                         bool binary = false);
void WriteTextAtomically(const std::string& path, const std::string& content);

// Unlinks the temporary files of the atomic writes in progress (in any thread). Async-signal-
// safe: for a signal handler that ends the process, so that none is left behind.
void RemoveTempFilesInProgress();

// Removes `dir`/<name>.tmp.<pid> for each of `names` whose pid is no running process: what a
// writer killed before its rename left behind. Other files are never touched.
void RemoveStaleTempFiles(const std::string& dir, const std::vector<std::string>& names);

// Throws DataError("<what> not found: <path>") unless `path` is a regular file.
void RequireFile(const std::string& path, const std::string& what);
// Throws DataError unless `path` is a directory.
void RequireDirectory(const std::string& path, const std::string& what);

// Joins two path components with exactly one '/'.
std::string JoinPath(const std::string& dir, const std::string& name);
// `path` if absolute, else `directory`/`path`.
std::string ResolvePath(const std::string& directory, const std::string& path);

}  // namespace ieslam
