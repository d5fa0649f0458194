#include "core/image_file.h"

#include <cctype>
#include <cstdint>
#include <vector>

#include <zlib.h>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "core/input_file.h"

namespace ieslam {
namespace {

bool StartsWith(const std::string& bytes, const char* magic, size_t size) {
  return bytes.size() >= size && bytes.compare(0, size, magic, size) == 0;
}

uint32_t BigEndian32(const std::string& bytes, size_t at) {
  uint32_t v = 0;
  for (size_t k = 0; k < 4; ++k) v = (v << 8) | static_cast<uint8_t>(bytes[at + k]);
  return v;
}

uint32_t LittleEndian32(const std::string& bytes, size_t at) {
  uint32_t v = 0;
  for (size_t k = 4; k > 0; --k) v = (v << 8) | static_cast<uint8_t>(bytes[at + k - 1]);
  return v;
}

// Complete when an end-of-image marker follows the last start-of-scan: entropy-coded data
// stuffs every FF byte, so neither marker occurs inside a scan, and a trailer after the image
// (a second MPO frame, vendor data) leaves the image's own FF D9 before it.
std::string JpegReason(const std::string& bytes) {
  const size_t last_scan = bytes.rfind("\xff\xda", std::string::npos, 2);
  if (last_scan != std::string::npos &&
      bytes.find("\xff\xd9", last_scan + 2, 2) != std::string::npos) {
    return "";
  }
  return "truncated: no end-of-image marker FF D9 after the last scan (" +
         std::to_string(bytes.size()) + " bytes)";
}

// Walks the chunk chain: a cut anywhere leaves the last chunk running past the end or no IEND.
std::string PngReason(const std::string& bytes) {
  size_t at = 8;
  std::string last = "the signature";
  while (at + 8 <= bytes.size()) {
    const uint64_t length = BigEndian32(bytes, at);
    const std::string type = bytes.substr(at + 4, 4);
    const uint64_t end = at + 12 + length;
    if (end > bytes.size()) {
      return "truncated: the PNG chunk '" + type + "' at byte " + std::to_string(at) + " needs " +
             std::to_string(end) + " bytes, the file has " + std::to_string(bytes.size());
    }
    // A critical chunk (upper-case first letter) whose CRC fails makes libpng fail the decode
    // with a line of its own on stderr; ancillary chunks it skips with a warning, and so do we.
    const uint32_t crc = BigEndian32(bytes, static_cast<size_t>(end) - 4);
    if (std::isupper(static_cast<unsigned char>(type[0])) &&
        crc32_z(0L, reinterpret_cast<const Bytef*>(bytes.data() + at + 4),
                static_cast<size_t>(length) + 4) != crc) {
      return "damaged: the CRC of PNG chunk '" + type + "' at byte " + std::to_string(at) +
             " does not match its data";
    }
    if (type == "IEND") return "";
    last = "chunk '" + type + "'";
    at = static_cast<size_t>(end);
  }
  return "truncated: the PNG ends after " + last + " without an IEND chunk (" +
         std::to_string(bytes.size()) + " bytes)";
}

// Binary PGM / PPM: "P5" or "P6", width, height, maxval (whitespace and # comments between),
// one whitespace byte, then the samples. A header that does not parse is left to the decoder.
std::string PnmReason(const std::string& bytes) {
  size_t at = 2;
  uint64_t fields[3] = {0, 0, 0};
  for (uint64_t& field : fields) {
    while (at < bytes.size()) {
      if (bytes[at] == '#') {
        while (at < bytes.size() && bytes[at] != '\n') ++at;
      } else if (std::isspace(static_cast<unsigned char>(bytes[at]))) {
        ++at;
      } else {
        break;
      }
    }
    const size_t digits = at;
    while (at < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[at])) &&
           at - digits < 9) {
      field = field * 10 + static_cast<uint64_t>(bytes[at] - '0');
      ++at;
    }
    if (at == digits || at >= bytes.size() || std::isdigit(static_cast<unsigned char>(bytes[at]))) {
      return "";
    }
  }
  if (!std::isspace(static_cast<unsigned char>(bytes[at])) || fields[2] == 0 || fields[2] > 65535) {
    return "";
  }
  ++at;
  const uint64_t channels = bytes[1] == '6' ? 3 : 1;
  const uint64_t sample_bytes = fields[2] < 256 ? 1 : 2;
  const uint64_t needed = fields[0] * fields[1] * channels * sample_bytes;
  const uint64_t present = bytes.size() - at;
  if (present >= needed) return "";
  return "truncated: the " + std::string(bytes[1] == '6' ? "PPM" : "PGM") + " header asks for " +
         std::to_string(needed) + " bytes of pixels, the file holds " + std::to_string(present);
}

std::string BmpReason(const std::string& bytes) {
  if (bytes.size() < 6) return "truncated: the BMP ends inside its header";
  const uint64_t declared = LittleEndian32(bytes, 2);
  if (declared <= bytes.size()) return "";
  return "truncated: the BMP header gives a size of " + std::to_string(declared) +
         " bytes, the file has " + std::to_string(bytes.size());
}

}  // namespace

std::string ImageFileDefect(const std::string& bytes) {
  if (StartsWith(bytes, "\xff\xd8\xff", 3)) return JpegReason(bytes);
  if (StartsWith(bytes, "\x89PNG\r\n\x1a\n", 8)) return PngReason(bytes);
  if (StartsWith(bytes, "P5", 2) || StartsWith(bytes, "P6", 2)) return PnmReason(bytes);
  if (StartsWith(bytes, "BM", 2)) return BmpReason(bytes);
  return "";
}

cv::Mat ReadImageFile(const std::string& path, int flags, const std::string& what) {
  std::string bytes = ReadInputFile(path, what, kMaxImageBytes);
  if (bytes.empty()) throw DataError("cannot decode " + what + " " + path + " (the file is empty)");
  const std::string defect = ImageFileDefect(bytes);
  if (!defect.empty()) throw DataError(what + " " + path + " is " + defect);
  cv::Mat image;
  try {
    const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1, bytes.data());
    image = cv::imdecode(buffer, flags);
  } catch (const cv::Exception& e) {
    throw DataError("cannot decode " + what + " " + path + ": " + e.msg);
  }
  if (image.empty()) {
    throw DataError("cannot decode " + what + " " + path + " (corrupt or not an image)");
  }
  return image;
}

}  // namespace ieslam
