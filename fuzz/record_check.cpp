// The record-file decoder check shared by fuzz_record_reader and its regression test.
#include "fuzz/record_check.h"

#include <cstdint>
#include <cstring>

#include "format/record_file.h"

namespace gaussmesh::fuzz {
namespace {

using format::RecordReader;

std::uint32_t u32_at(std::string_view bytes, std::size_t at) {
  std::uint32_t v = 0;
  if (at + 4 <= bytes.size()) std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

std::string read_all(const std::string& path, std::uint32_t kind, std::uint32_t record_size, bool decode) {
  auto reader = RecordReader::open(path, kind, record_size);
  if (!reader.is_ok()) return reader.status().message().empty() ? "an open error without a message" : "";
  std::uint64_t records = 0;
  for (;;) {
    if (decode) {
      auto frame = (*reader)->next();
      if (!frame.is_ok()) return frame.status().message().empty() ? "an error without a message" : "";
      if (frame->empty()) break;
      if (frame->size() % record_size != 0) return "a frame that is not whole records";
      records += frame->size() / record_size;
    } else {
      auto skipped = (*reader)->skip();
      if (!skipped.is_ok()) return skipped.status().message().empty() ? "an error without a message" : "";
      if (*skipped == 0) break;
      records += *skipped;
    }
  }
  if (records != (*reader)->records()) return "a clean end with a record count other than the file claims";
  return "";
}

}  // namespace

std::string check_record_file(const std::string& path, std::string_view header) {
  const std::uint32_t kind = u32_at(header, 12);
  std::uint32_t record_size = u32_at(header, 16);
  if (record_size == 0 || record_size > format::kMaxRecordFrameBytes) record_size = 1;
  std::string broken = read_all(path, kind, record_size, /*decode=*/true);
  if (broken.empty()) broken = read_all(path, kind, record_size, /*decode=*/false);
  return broken;
}

}  // namespace gaussmesh::fuzz
