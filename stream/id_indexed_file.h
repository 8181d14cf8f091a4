// Positioned whole reads and writes (the loop stitch's files), and reading fixed-size records by
// ascending id from a file indexed by id (record i at byte first_byte + i * record_bytes): the
// partition's vertex files and the input's own vertex records (load_chunk), and the loop
// stitch's positions file (the mesher's batched reads).
#pragma once

#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace gaussmesh::stream {

// size bytes at offset, through short writes and interruptions; false (errno set) when the
// file cannot take them (a full disk).
inline bool write_all_at(int fd, const void* data, std::size_t size, std::uint64_t offset) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t put = ::pwrite(fd, bytes, size, static_cast<off_t>(offset));
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

// size bytes from offset, through short reads and interruptions; false at end of file or on an
// error.
inline bool read_all_at(int fd, void* out, std::size_t size, std::uint64_t offset) {
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

// Calls fn(i, record) for ids[i], i = 0, 1, ..., with ids ascending: one pread per run of ids
// less than kIdWindowRecords apart (spatially ordered input: a few per chunk; scattered ids: one
// per id), `window` reused between calls. Stops at the first id it cannot serve — at or beyond
// `count` records, not above the one before, or in a short read — and returns how many it
// served (ids.size() when all).
inline constexpr std::size_t kIdWindowRecords = 4096;
template <class Fn>
std::size_t read_by_ascending_id(int fd, std::uint64_t count, std::size_t record_bytes, std::span<const std::uint32_t> ids,
                                 std::vector<std::byte>& window, Fn&& fn, std::uint64_t first_byte = 0) {
  std::size_t i = 0;
  while (i < ids.size()) {
    const std::uint64_t base = ids[i];
    if (base >= count || (i > 0 && ids[i] <= ids[i - 1])) return i;
    std::size_t end = i + 1;
    while (end < ids.size() && ids[end] > ids[end - 1] && ids[end] < base + kIdWindowRecords && ids[end] < count) ++end;
    const std::size_t bytes = static_cast<std::size_t>(ids[end - 1] - base + 1) * record_bytes;
    window.resize(bytes);
    std::size_t done = 0;
    while (done < bytes) {
      const ssize_t got = ::pread(fd, window.data() + done, bytes - done, static_cast<off_t>(first_byte + base * record_bytes + done));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) return i;
      done += static_cast<std::size_t>(got);
    }
    for (; i < end; ++i) fn(i, window.data() + (ids[i] - base) * record_bytes);
  }
  return i;
}

}  // namespace gaussmesh::stream
