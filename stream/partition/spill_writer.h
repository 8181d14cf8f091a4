// A sequential spill file: buffered writes of one temporary file, in order (the ingest pass's position
// files, the owner pass's owners.bin).
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>

#include "format/file_io.h"
#include "format/status.h"
#include "stream/partition/posix_io.h"

namespace gaussmesh::stream::detail {

using format::Code;
using format::Status;

class SpillWriter {
 public:
  ~SpillWriter() {
    if (fd_ >= 0) ::close(fd_);
  }
  Status open(const std::string& path, std::size_t buffer_bytes) {
    path_ = path;
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd_ < 0) return Status::error(Code::kOutput, path, "cannot create temporary file: " + errno_text());
    buffer_.reset(new std::byte[buffer_bytes]);
    capacity_ = buffer_bytes;
    return {};
  }
  Status write(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const std::byte*>(data);
    while (size > 0) {
      if (used_ == capacity_) GM_RETURN_IF_ERROR(flush());
      const std::size_t take = std::min(size, capacity_ - used_);
      std::memcpy(buffer_.get() + used_, bytes, take);
      used_ += take;
      bytes += take;
      size -= take;
    }
    return {};
  }
  Status close() {
    GM_RETURN_IF_ERROR(flush());
    buffer_.reset();
    const int fd = fd_;
    fd_ = -1;
    if (fd >= 0 && ::close(fd) != 0) return Status::error(Code::kOutput, path_, "close failed: " + errno_text());
    return {};
  }
  std::uint64_t bytes() const { return total_; }

 private:
  Status flush() {
    if (used_ == 0) return {};
    if (!format::write_all(fd_, buffer_.get(), used_, 0, false)) {
      return Status::error(Code::kOutput, path_, "write failed: " + errno_text());
    }
    total_ += used_;
    used_ = 0;
    return {};
  }
  int fd_ = -1;
  std::string path_;
  std::unique_ptr<std::byte[]> buffer_;
  std::size_t capacity_ = 0, used_ = 0;
  std::uint64_t total_ = 0;
};

}  // namespace gaussmesh::stream::detail
