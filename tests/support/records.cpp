#include "tests/support/records.h"

#include "format/record_file.h"

namespace gaussmesh::testing {

format::Result<std::vector<std::byte>> read_all_records(const std::string& path, std::uint32_t kind,
                                                        std::uint32_t record_bytes) {
  auto reader = format::RecordReader::open(path, kind, record_bytes);
  if (!reader) return reader.status();
  std::vector<std::byte> records;
  for (;;) {
    auto frame = (*reader)->next();
    if (!frame) return frame.status();
    if (frame->empty()) return records;
    records.insert(records.end(), frame->begin(), frame->end());
  }
}

format::Status write_all_records(const std::string& path, std::uint32_t kind, std::uint32_t record_bytes,
                                 std::span<const std::byte> records) {
  auto writer = format::RecordWriter::create(path, kind, record_bytes);
  if (!writer) return writer.status();
  GM_RETURN_IF_ERROR((*writer)->append(records));
  return (*writer)->finish();
}

}  // namespace gaussmesh::testing
