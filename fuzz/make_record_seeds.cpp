// Writes small valid record files (docs/records.md) into a directory, as seeds for
// fuzz_record_reader: plain and column frames, one and several frames, delta fields, no records.
// Usage: make_record_seeds DIR
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "format/record_file.h"

namespace {

using namespace gaussmesh::format;

bool write_seed(const std::string& path, std::uint32_t record_size, std::size_t records, const RecordWriterOptions& options) {
  auto writer = RecordWriter::create(path, 0x47434D47, record_size, options);
  if (!writer.is_ok()) {
    std::fprintf(stderr, "%s\n", writer.status().to_string().c_str());
    return false;
  }
  std::vector<std::byte> bytes(record_size * records);
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::byte>((i * 7 + i / record_size) & 0xFF);
  Status status = (*writer)->append(bytes);
  if (status.is_ok()) status = (*writer)->finish();
  if (!status.is_ok()) std::fprintf(stderr, "%s\n", status.to_string().c_str());
  return status.is_ok();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_record_seeds DIR\n");
    return 1;
  }
  const std::string dir = argv[1];
  RecordWriterOptions plain;
  RecordWriterOptions small_frames;
  small_frames.frame_bytes = 64;
  RecordWriterOptions columns;
  columns.columns = {{8, true}, {4, true}, {4, false}, {1, false}};
  columns.frame_bytes = 128;
  bool ok = write_seed(dir + "/empty.rec", 12, 0, plain) && write_seed(dir + "/one-frame.rec", 12, 20, plain) &&
            write_seed(dir + "/frames.rec", 12, 40, small_frames) && write_seed(dir + "/columns.rec", 17, 30, columns);
  return ok ? 0 : 1;
}
