#include "core/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/error.h"

namespace ieslam {
namespace {

[[noreturn]] void TooLarge(const std::string& path, const std::string& what, std::uintmax_t size,
                           std::uintmax_t max_bytes) {
  throw DataError(what + " is " + std::to_string(size) + " bytes, more than the " +
                  std::to_string(max_bytes) + " allowed: " + path);
}

void CheckStat(const struct stat& st, const std::string& path, const std::string& what,
               std::uintmax_t max_bytes) {
  if (!S_ISREG(st.st_mode)) throw DataError(what + " is not a regular file: " + path);
  const auto size = static_cast<std::uintmax_t>(st.st_size);
  if (size > max_bytes) TooLarge(path, what, size, max_bytes);
}

// Closes the descriptor on every way out of ReadInputFile.
class Descriptor {
 public:
  explicit Descriptor(int fd) : fd_(fd) {}
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace

void RequireRegularInputFile(const std::string& path, const std::string& what,
                             std::uintmax_t max_bytes) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) throw DataError(what + " not found: " + path);
    throw DataError(what + " cannot be read: " + path + ": " + std::strerror(errno));
  }
  CheckStat(st, path, what, max_bytes);
}

std::string ReadInputFile(const std::string& path, const std::string& what,
                          std::uintmax_t max_bytes) {
  RequireRegularInputFile(path, what, max_bytes);
  // O_NONBLOCK: should the path have become a FIFO since the stat, open() still returns.
  const Descriptor fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC));
  if (fd.get() < 0) {
    throw DataError(what + " cannot be read: " + path + ": " + std::strerror(errno));
  }
  struct stat st;
  if (::fstat(fd.get(), &st) != 0) {
    throw DataError(what + " cannot be read: " + path + ": " + std::strerror(errno));
  }
  CheckStat(st, path, what, max_bytes);
  std::string text;
  text.reserve(static_cast<size_t>(st.st_size));
  char buffer[65536];
  for (;;) {
    const ssize_t n = ::read(fd.get(), buffer, sizeof(buffer));
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      throw DataError(what + " cannot be read: " + path + ": " + std::strerror(errno));
    }
    text.append(buffer, static_cast<size_t>(n));
    if (text.size() > max_bytes) TooLarge(path, what, text.size(), max_bytes);
  }
  return text;
}

}  // namespace ieslam
