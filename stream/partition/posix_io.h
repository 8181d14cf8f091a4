// POSIX helpers the partition's files share: errno as text, a pread loop that reads what was
// asked unless the file ends first, and a descriptor closed at the end of its scope.
#pragma once

#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace gaussmesh::stream::detail {

inline std::string errno_text() { return std::strerror(errno); }

// Reads up to size bytes at offset; returns the count read (short at end of file), -1 on error.
inline std::int64_t read_some(int fd, void* out, std::size_t size, std::uint64_t offset) {
  char* bytes = static_cast<char*>(out);
  std::size_t done = 0;
  while (done < size) {
    ssize_t got = ::pread(fd, bytes + done, size - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return -1;
    if (got == 0) break;
    done += static_cast<std::size_t>(got);
  }
  return static_cast<std::int64_t>(done);
}

// Closes a descriptor when it goes out of scope.
struct FdCloser {
  int fd;
  ~FdCloser() { ::close(fd); }
};

}  // namespace gaussmesh::stream::detail
