// Output that never leaves a partial file behind: written under a temporary name beside the
// target and renamed on commit; "-" writes to standard output. Temporary names are registered
// so that SIGINT/SIGTERM remove them (see temp_registry.h).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "format/status.h"

namespace gaussmesh::format {

class OutputFile {
 public:
  // path "-" is standard output; binary output to a terminal is refused (kUsage). An existing
  // path that is not a regular file (/dev/null, a FIFO) is written in place, without a rename.
  static Result<std::unique_ptr<OutputFile>> create(const std::string& path, bool binary);
  ~OutputFile();  // removes the temporary file unless commit() succeeded
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  Status write(const void* data, size_t size);
  Status write(std::string_view text) { return write(text.data(), text.size()); }
  // Flushes, and for a file renames it onto the target. After an error nothing is left.
  Status commit();
  const std::string& name() const { return display_; }
  // Bytes handed to write() so far.
  std::uint64_t bytes_written() const { return total_; }

 private:
  OutputFile() = default;
  Status flush();
  int fd_ = -1;
  int slot_ = -1;  // temp_registry slot of temp_
  std::string target_, temp_, display_;
  std::unique_ptr<char[]> buffer_;
  size_t used_ = 0;
  std::uint64_t total_ = 0;
  bool committed_ = false;
  bool in_place_ = false;  // a device or a pipe, written directly and closed by the destructor
  bool failed_ = false;
};

}  // namespace gaussmesh::format
