#include "core/file_util.h"

#include <filesystem>
#include <fstream>
#include <system_error>

#include <unistd.h>

#include "core/error.h"

namespace ieslam {

void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                         bool binary) {
  // The pid keeps concurrent writers of the same path (two runs) from sharing a temp file.
  const std::string temp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(temp, binary ? std::ios::binary | std::ios::trunc : std::ios::trunc);
    if (!out) throw DataError("cannot write " + temp + " (is the output directory writable?)");
    write(out);
    out.flush();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temp, ignored);
      throw DataError("write failed for " + temp + " (disk full?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw DataError("cannot rename " + temp + " to " + path + ": " + ec.message());
  }
}

void WriteTextAtomically(const std::string& path, const std::string& content) {
  WriteFileAtomically(path, [&content](std::ostream& out) { out << content; });
}

void RequireFile(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw DataError(what + " not found: " + path);
  }
}

void RequireDirectory(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_directory(path, ec)) {
    throw DataError(what + " is not a directory: " + path);
  }
}

std::string JoinPath(const std::string& dir, const std::string& name) {
  if (dir.empty()) return name;
  if (dir.back() == '/') return dir + name;
  return dir + "/" + name;
}

std::string ResolvePath(const std::string& directory, const std::string& path) {
  if (!path.empty() && path.front() == '/') return path;
  return JoinPath(directory, path);
}

}  // namespace ieslam
