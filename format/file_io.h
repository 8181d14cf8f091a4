// Whole reads and writes on a file descriptor, through short transfers and interruptions: the
// record files, the partition's spills and cache, and the loop stitch's plain files use these.
#pragma once

#include <cstddef>
#include <cstdint>

namespace gaussmesh::format {

// size bytes at offset (positioned: pwrite), or at the descriptor's position (write). False,
// errno set, when the file cannot take them (a full disk; EIO when a write takes nothing).
bool write_all(int fd, const void* data, std::size_t size, std::uint64_t offset, bool positioned = true);

// size bytes from offset (pread). False at end of file or on an error.
bool pread_all(int fd, void* out, std::size_t size, std::uint64_t offset);

}  // namespace gaussmesh::format
