#include "core/file_util.h"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

#include <signal.h>
#include <unistd.h>

#include "core/error.h"

namespace ieslam {
namespace {

// The temp paths of the writes in progress, in fixed slots a signal handler can read: a slot
// is free (0), being filled (1) or holds a path (2). A write that finds no free slot (more
// than kTempSlots at once) goes unregistered; RemoveStaleTempFiles cleans up after it.
constexpr int kTempSlots = 32;
constexpr size_t kTempPathSize = 4096;
char g_temp_paths[kTempSlots][kTempPathSize];
std::atomic<int> g_temp_state[kTempSlots];
static_assert(std::atomic<int>::is_always_lock_free, "a signal handler reads the slots");

// Holds `path` in a slot for its lifetime.
class RegisteredTemp {
 public:
  explicit RegisteredTemp(const std::string& path) {
    if (path.size() >= kTempPathSize) return;
    for (int k = 0; k < kTempSlots; ++k) {
      int expected = 0;
      if (!g_temp_state[k].compare_exchange_strong(expected, 1)) continue;
      std::memcpy(g_temp_paths[k], path.c_str(), path.size() + 1);
      g_temp_state[k].store(2);
      slot_ = k;
      return;
    }
  }
  ~RegisteredTemp() {
    if (slot_ >= 0) g_temp_state[slot_].store(0);
  }
  RegisteredTemp(const RegisteredTemp&) = delete;
  RegisteredTemp& operator=(const RegisteredTemp&) = delete;

 private:
  int slot_ = -1;
};

}  // namespace

void RemoveTempFilesInProgress() {
  for (int k = 0; k < kTempSlots; ++k) {
    if (g_temp_state[k].load() == 2) ::unlink(g_temp_paths[k]);
  }
}

void RemoveStaleTempFiles(const std::string& dir, const std::vector<std::string>& names) {
  std::error_code ec;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string file = it->path().filename().string();
    for (const std::string& name : names) {
      const std::string prefix = name + ".tmp.";
      if (file.size() <= prefix.size() || file.compare(0, prefix.size(), prefix) != 0) continue;
      const std::string pid = file.substr(prefix.size());
      if (pid.size() > 9 || pid.find_first_not_of("0123456789") != std::string::npos) continue;
      const pid_t owner = static_cast<pid_t>(std::stol(pid));
      // kill(pid, 0) fails with ESRCH only when no process has that pid.
      if (owner <= 0 || owner == ::getpid() || ::kill(owner, 0) == 0 || errno != ESRCH) continue;
      std::error_code ignored;
      std::filesystem::remove(it->path(), ignored);
    }
  }
}

void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                         bool binary) {
  // The pid keeps concurrent writers of the same path (two runs) from sharing a temp file.
  const std::string temp = path + ".tmp." + std::to_string(::getpid());
  const RegisteredTemp registered(temp);
  {
    std::ofstream out(temp, binary ? std::ios::binary | std::ios::trunc : std::ios::trunc);
    if (!out) throw OutputError("cannot write " + temp + " (is the output directory writable?)");
    write(out);
    out.flush();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temp, ignored);
      throw OutputError("write failed for " + temp + " (disk full?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw OutputError("cannot rename " + temp + " to " + path + ": " + ec.message());
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
