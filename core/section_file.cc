#include "core/section_file.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>

#include <glog/logging.h>
#include <zlib.h>

#include "core/error.h"
#include "core/file_util.h"

namespace ieslam {
namespace {

constexpr size_t kHeaderBytes = 8 + 4 + 4 + 4;
constexpr size_t kSectionHeaderBytes = 4 + 8 + 4;

// The CRC-32 of `data` continued from `crc_before`, that of the bytes before it (0: of none).
uint32_t Crc32(const char* data, size_t n, uint32_t crc_before = 0) {
  uLong crc = crc_before;
  // zlib takes at most a uInt's worth of bytes per call.
  while (n > 0) {
    const uInt chunk = static_cast<uInt>(std::min<size_t>(n, 1u << 30));
    crc = crc32(crc, reinterpret_cast<const Bytef*>(data), chunk);
    data += chunk;
    n -= chunk;
  }
  return static_cast<uint32_t>(crc);
}

template <typename T>
T Load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

}  // namespace

void SectionSink::Begin(const std::string& tag) {
  CHECK(!open_) << "a section begins before the last one ended";
  CHECK_EQ(tag.size(), 4u) << "a section's tag has 4 characters";
  head_ = out_->tellp();
  SectionWriter head;
  head.Bytes(tag.data(), 4);
  head.U64(0);  // the length and the checksum, filled in by End()
  head.U32(0);
  out_->write(head.payload().data(), static_cast<std::streamsize>(head.payload().size()));
  length_ = 0;
  crc_ = 0;  // of no bytes
  open_ = true;
}

void SectionSink::Append(const std::string& bytes) {
  CHECK(open_) << "bytes outside a section";
  out_->write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  length_ += bytes.size();
  crc_ = Crc32(bytes.data(), bytes.size(), crc_);
}

void SectionSink::End() {
  CHECK(open_) << "no section to end";
  const std::streampos end = out_->tellp();
  SectionWriter fields;
  fields.U64(length_);
  fields.U32(crc_);
  out_->seekp(head_ + std::streamoff(4));
  out_->write(fields.payload().data(), static_cast<std::streamsize>(fields.payload().size()));
  out_->seekp(end);
  open_ = false;
  ++sections_;
}

void WriteSectionFile(const std::string& path, const std::string& magic, uint32_t version,
                      uint32_t sections, const std::function<void(SectionSink*)>& write) {
  CHECK_EQ(magic.size(), 8u) << "a section file's magic has 8 characters";
  SectionWriter header;
  header.Bytes(magic.data(), magic.size());
  header.U32(version);
  header.U32(sections);
  header.U32(Crc32(header.payload().data(), header.payload().size()));
  WriteFileAtomically(
      path,
      [&](std::ostream& out) {
        out.write(header.payload().data(), static_cast<std::streamsize>(header.payload().size()));
        SectionSink sink(&out);
        write(&sink);
        CHECK_EQ(sink.sections(), static_cast<int>(sections)) << "sections written of " << path;
      },
      /*binary=*/true);
}

void WriteSectionFile(const std::string& path, const std::string& magic, uint32_t version,
                      const std::vector<FileSection>& sections) {
  WriteSectionFile(path, magic, version, static_cast<uint32_t>(sections.size()),
                   [&](SectionSink* sink) {
                     for (const FileSection& section : sections) {
                       sink->Begin(section.tag);
                       sink->Append(section.payload);
                       sink->End();
                     }
                   });
}

std::vector<FileSection> ReadSectionFile(const std::string& path, const std::string& magic,
                                         uint32_t version, const std::string& kind) {
  CHECK_EQ(magic.size(), 8u) << "a section file's magic has 8 characters";
  RequireFile(path, "file");
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw DataError(path + ": cannot be read");
  if (bytes.size() < kHeaderBytes) {
    throw DataError(path + ": truncated (" + std::to_string(bytes.size()) +
                    " bytes, shorter than the header)");
  }
  if (bytes.compare(0, 8, magic) != 0) {
    throw DataError(path + ": not " + kind + " (its first bytes are not \"" + magic + "\")");
  }
  const uint32_t file_version = Load<uint32_t>(bytes.data() + 8);
  const uint32_t count = Load<uint32_t>(bytes.data() + 12);
  if (Load<uint32_t>(bytes.data() + 16) != Crc32(bytes.data(), 16)) {
    throw DataError(path + ": the header's checksum does not match (the file is corrupted)");
  }
  if (file_version != version) {
    throw DataError(path + ": format version " + std::to_string(file_version) +
                    ", this build reads version " + std::to_string(version));
  }
  std::vector<FileSection> sections;
  size_t pos = kHeaderBytes;
  for (uint32_t k = 0; k < count; ++k) {
    if (bytes.size() - pos < kSectionHeaderBytes) {
      throw DataError(path + ": truncated in section " + std::to_string(k + 1) + " of " +
                      std::to_string(count) + " (its header)");
    }
    FileSection section;
    section.tag = bytes.substr(pos, 4);
    const uint64_t length = Load<uint64_t>(bytes.data() + pos + 4);
    const uint32_t crc = Load<uint32_t>(bytes.data() + pos + 12);
    pos += kSectionHeaderBytes;
    if (bytes.size() - pos < length) {
      throw DataError(path + ": truncated in section '" + section.tag + "' (" +
                      std::to_string(bytes.size() - pos) + " of its " + std::to_string(length) +
                      " bytes)");
    }
    section.payload = bytes.substr(pos, length);
    pos += length;
    if (Crc32(section.payload.data(), section.payload.size()) != crc) {
      throw DataError(path + ": the checksum of section '" + section.tag +
                      "' does not match (the file is corrupted)");
    }
    sections.push_back(std::move(section));
  }
  if (pos != bytes.size()) {
    throw DataError(path + ": " + std::to_string(bytes.size() - pos) +
                    " bytes after the last section");
  }
  return sections;
}

void SectionWriter::String(const std::string& s) {
  U64(s.size());
  Raw(s.data(), s.size());
}

std::string SectionReader::String() {
  const size_t n = Count(1);
  std::string s(n, '\0');
  Bytes(s.data(), n);
  return s;
}

void SectionReader::Bytes(void* data, size_t n) {
  if (payload_.size() - pos_ < n) Fail("ends early");
  std::memcpy(data, payload_.data() + pos_, n);
  pos_ += n;
}

size_t SectionReader::Count(size_t item_bytes) {
  const uint64_t n = U64();
  if (item_bytes > 0 && n > (payload_.size() - pos_) / item_bytes) {
    Fail("a count of " + std::to_string(n) + " is more than the rest can hold");
  }
  return static_cast<size_t>(n);
}

void SectionReader::Finish() const {
  if (pos_ != payload_.size()) {
    Fail(std::to_string(payload_.size() - pos_) + " bytes left over");
  }
}

void SectionReader::Fail(const std::string& why) const { throw DataError(what_ + ": " + why); }

}  // namespace ieslam
