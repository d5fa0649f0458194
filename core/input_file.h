// Opening the files a user names (calibrations, configs, lists, trajectories, stored
// problems, images) without hanging or exhausting memory: a FIFO would block the open or
// the read forever, and a device such as /dev/zero never ends, so each input is stat()ed
// before it is opened and refused unless it is a regular file of bounded size.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

namespace ieslam {

// No size bound, for inputs whose size the reader does not hold in memory.
constexpr std::uintmax_t kNoSizeBound = std::numeric_limits<std::uintmax_t>::max();
// An image is read whole before it is decoded: an uncompressed 8K 16-bit RGB frame is about
// 200 MB, so 256 MiB holds any camera's frame and keeps a mislabelled huge file out of memory.
constexpr std::uintmax_t kMaxImageBytes = std::uintmax_t{256} << 20;

// Caps by kind of input (a YAML file's is kMaxYamlBytes in core/yaml_text.h). A TUM image
// list or trajectory line is under 100 bytes, so 1 GiB is ten million frames, days of video
// at 30 Hz.
constexpr std::uintmax_t kMaxListFileBytes = std::uintmax_t{1} << 30;
// A stored bundle-adjustment problem line is one observation of about 60 bytes: 4 GiB is
// some seventy million observations, more than the refinement can hold in memory here.
constexpr std::uintmax_t kMaxBaProblemBytes = std::uintmax_t{4} << 30;
// A 7-Scenes pose or intrinsics file holds 9 or 16 numbers.
constexpr std::uintmax_t kMaxSmallTextBytes = std::uintmax_t{64} << 10;

// Throws DataError "<what> not found: <path>" when nothing is there, "<what> is not a
// regular file: <path>" for a FIFO, a device, a socket or a directory (symlinks are
// followed), and "<what> is N bytes, more than the M allowed: <path>" above `max_bytes`.
// Never opens `path`; for readers that stream the file themselves after the check.
void RequireRegularInputFile(const std::string& path, const std::string& what,
                             std::uintmax_t max_bytes = kNoSizeBound);

// The whole content of `path` after RequireRegularInputFile's checks. The file is opened
// non-blocking and checked again on the open descriptor (it may have been replaced since),
// and reading stops past `max_bytes` (it may have grown). DataError naming `what` and
// `path` when it cannot be read.
std::string ReadInputFile(const std::string& path, const std::string& what,
                          std::uintmax_t max_bytes);

}  // namespace ieslam
