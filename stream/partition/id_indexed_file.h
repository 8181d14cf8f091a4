// Reading fixed-size records by ascending id from a file indexed by id (record i at byte
// first_byte + i * record_bytes): the partition's vertex files and the input's own vertex
// records (load_chunk), and the loop stitch's positions file (the mesher's batched reads).
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace gaussmesh::stream {

// Calls fn(i, record) for ids[i], i = 0, 1, ..., with ids ascending: one pread per run of ids
// within kIdWindowRecords of the run's first and at most kIdGapBytes of records apart
// (spatially ordered input: a few per chunk; scattered ids: one per id), `window` reused
// between calls. Stops at the first id it cannot serve — at or beyond `count` records, not
// above the one before, or in a short read — and returns how many it served (ids.size() when
// all). The gap: a pread costs about what copying 8 KiB does here, and sparse id sets (the loops pass's
// loop chunks, a fifth of the faces scattered along patch borders) read mostly bytes between
// their ids when a run could reach 4,096 records ahead.
inline constexpr std::size_t kIdWindowRecords = 4096;
inline constexpr std::size_t kIdGapBytes = 8192;
template <class Fn>
std::size_t read_by_ascending_id(int fd, std::uint64_t count, std::size_t record_bytes, std::span<const std::uint32_t> ids,
                                 std::vector<std::byte>& window, Fn&& fn, std::uint64_t first_byte = 0) {
  const std::uint64_t max_gap = std::max<std::size_t>(kIdGapBytes / record_bytes, 1);  // in records
  std::size_t i = 0;
  while (i < ids.size()) {
    const std::uint64_t base = ids[i];
    if (base >= count || (i > 0 && ids[i] <= ids[i - 1])) return i;
    std::size_t end = i + 1;
    while (end < ids.size() && ids[end] > ids[end - 1] && ids[end] - ids[end - 1] <= max_gap && ids[end] < base + kIdWindowRecords &&
           ids[end] < count)
      ++end;
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
