#include "format/file_io.h"

#include <unistd.h>

#include <cerrno>

namespace gaussmesh::format {

bool write_all(int fd, const void* data, std::size_t size, std::uint64_t offset, bool positioned) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t put = positioned ? ::pwrite(fd, bytes, size, static_cast<off_t>(offset)) : ::write(fd, bytes, size);
    if (put < 0 && errno == EINTR) continue;
    if (put <= 0) {
      if (put == 0) errno = EIO;
      return false;
    }
    bytes += put;
    size -= static_cast<std::size_t>(put);
    offset += static_cast<std::uint64_t>(put);
  }
  return true;
}

bool pread_all(int fd, void* out, std::size_t size, std::uint64_t offset) {
  char* bytes = static_cast<char*>(out);
  while (size > 0) {
    const ssize_t got = ::pread(fd, bytes, size, static_cast<off_t>(offset));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return false;
    bytes += got;
    size -= static_cast<std::size_t>(got);
    offset += static_cast<std::uint64_t>(got);
  }
  return true;
}

}  // namespace gaussmesh::format
