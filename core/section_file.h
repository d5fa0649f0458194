// A versioned binary file of tagged sections, each with its length and CRC-32, so that a
// reader tells a file of another kind, another format version, a truncated file and a
// corrupted one apart and says which.
//
// Layout, every integer little-endian:
//   header   magic (8 bytes), format version (u32), number of sections (u32),
//            CRC-32 of the 16 bytes before it (u32)
//   section  tag (4 ASCII bytes), payload length (u64), CRC-32 of the payload (u32), payload
// and nothing after the last section. Payloads are written and read with SectionWriter and
// SectionReader: integers little-endian, doubles and floats as their IEEE-754 bits
// (bit-exact round trips), strings and arrays with a u64 length first.
#pragma once

#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace ieslam {

// Little-endian, as the layout says (the writers copy the host's bytes).
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "section files assume little-endian");

struct FileSection {
  std::string tag;  // 4 characters
  std::string payload;
};

// Takes a section file's sections as they are produced, piece by piece, so that no whole
// payload needs to be held: each section's length and checksum are filled in at its End().
class SectionSink {
 public:
  explicit SectionSink(std::ostream* out) : out_(out) {}
  void Begin(const std::string& tag);  // 4 characters (CHECKed)
  void Append(const std::string& bytes);
  void End();
  int sections() const { return sections_; }

 private:
  std::ostream* out_;
  std::streampos head_;
  uint64_t length_ = 0;
  uint32_t crc_ = 0;
  bool open_ = false;
  int sections_ = 0;
};

// Writes a section file atomically (core/file_util.h): the header, then what `write` gives
// the sink, which must be `sections` sections, each ended (CHECKed). `magic` has 8
// characters (CHECKed). Throws OutputError naming the path when it cannot be written.
void WriteSectionFile(const std::string& path, const std::string& magic, uint32_t version,
                      uint32_t sections, const std::function<void(SectionSink*)>& write);
// The same with every payload at hand.
void WriteSectionFile(const std::string& path, const std::string& magic, uint32_t version,
                      const std::vector<FileSection>& sections);

// Reads a file WriteSectionFile wrote with this magic and version. Throws DataError naming
// the path and what is wrong: missing, not `kind` (e.g. "an ieslam map": the magic), another format
// version, truncated (in which section), a checksum that does not match (of which section),
// or bytes after the last section.
std::vector<FileSection> ReadSectionFile(const std::string& path, const std::string& magic,
                                         uint32_t version, const std::string& kind);

// A payload built field by field.
class SectionWriter {
 public:
  void U8(uint8_t v) { Raw(&v, 1); }
  void U32(uint32_t v) { Raw(&v, sizeof v); }
  void I32(int32_t v) { Raw(&v, sizeof v); }
  void I64(int64_t v) { Raw(&v, sizeof v); }
  void U64(uint64_t v) { Raw(&v, sizeof v); }
  void F32(float v) { Raw(&v, sizeof v); }
  void F64(double v) { Raw(&v, sizeof v); }
  void String(const std::string& s);
  void Bytes(const void* data, size_t n) { Raw(data, n); }

  const std::string& payload() const { return payload_; }
  // The payload so far; the writer starts afresh.
  std::string Take() {
    std::string taken = std::move(payload_);
    payload_.clear();
    return taken;
  }

 private:
  void Raw(const void* data, size_t n) { payload_.append(static_cast<const char*>(data), n); }
  std::string payload_;
};

// Reads a payload field by field. Every read past the end throws DataError naming `what`
// (the file and section), as does Finish() when bytes are left over: a payload must be
// read exactly.
class SectionReader {
 public:
  SectionReader(const std::string& payload, std::string what)
      : payload_(payload), what_(std::move(what)) {}

  uint8_t U8() { return Get<uint8_t>(); }
  uint32_t U32() { return Get<uint32_t>(); }
  int32_t I32() { return Get<int32_t>(); }
  int64_t I64() { return Get<int64_t>(); }
  uint64_t U64() { return Get<uint64_t>(); }
  float F32() { return Get<float>(); }
  double F64() { return Get<double>(); }
  std::string String();
  void Bytes(void* data, size_t n);
  // A count of items of `item_bytes` each that the rest of the payload must be able to
  // hold: a corrupted count is an error, never a huge allocation.
  size_t Count(size_t item_bytes);
  size_t remaining() const { return payload_.size() - pos_; }
  void Finish() const;
  // Throws DataError: "<what>: <why>".
  [[noreturn]] void Fail(const std::string& why) const;

 private:
  template <typename T>
  T Get() {
    T v;
    Bytes(&v, sizeof v);
    return v;
  }

  const std::string& payload_;
  std::string what_;
  size_t pos_ = 0;
};

}  // namespace ieslam
