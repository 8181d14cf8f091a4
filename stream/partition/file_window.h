// A small read-only window on one file, for one thread: the face scans' read-ahead thread reads
// owners and bitmap bits through it while the block cache stays single-threaded.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "stream/partition/posix_io.h"

namespace gaussmesh::stream::detail {

// A read-only window on one of the cache's files (owners.bin, or a bitmap the cache has
// flushed), for one thread: 4 KiB blocks in two-way sets (the least recently used way goes), a
// pread per miss, zeros past the end of the file (blocks never written read as zeros, as in the
// cache). The scans' tags read through these on the read-ahead thread, beside the
// single-threaded cache. Two ways, not one: a face's corners often lie in two hot blocks (a
// refined face's interior ids and one of its edges' ids) that a direct-mapped window would put
// on one slot, missing on every other face. A failed read reads as zeros and keeps its error
// (error()), which the tagger returns after the frame.
class FileWindow {
 public:
  static constexpr std::size_t kBlockBytes = 4096;
  FileWindow(int fd, std::size_t bytes) : fd_(fd) {
    std::size_t sets = 2;
    while (sets * 4 * kBlockBytes <= bytes) sets *= 2;
    mask_ = sets - 1;
    keys_.assign(2 * sets, kEmpty);
    evict_.assign(sets, 0);
    data_.reset(new std::byte[2 * sets * kBlockBytes]);
  }
  std::uint32_t u32(std::uint64_t i) {
    std::uint32_t value;
    std::memcpy(&value, at(4 * i), 4);
    return value;
  }
  bool bit(std::uint64_t i) { return (std::to_integer<unsigned>(*at(i / 8)) >> (i % 8)) & 1u; }
  // The first read error's text, empty when every read worked.
  const std::string& error() const { return error_; }
  std::uint64_t misses() const { return misses_; }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  const std::byte* at(std::uint64_t byte) {
    const std::uint64_t block = byte / kBlockBytes;
    // A face's corners, and the next face's, mostly lie in one block (1,024 owners, 32,768
    // frontier bits): the last block found answers first.
    if (block == last_block_) return last_data_ + byte % kBlockBytes;
    const std::size_t set = static_cast<std::size_t>(block & mask_);
    std::size_t slot = 2 * set;
    if (keys_[slot] != block) [[unlikely]] {
      if (keys_[slot + 1] == block) {
        ++slot;
      } else {
        ++misses_;
        slot += evict_[set];
        std::byte* data = data_.get() + slot * kBlockBytes;
        const std::int64_t got = read_some(fd_, data, kBlockBytes, block * kBlockBytes);
        if (got < 0 && error_.empty()) error_ = errno_text();
        const std::size_t kept = got > 0 ? static_cast<std::size_t>(got) : 0;
        std::memset(data + kept, 0, kBlockBytes - kept);
        keys_[slot] = block;
      }
    }
    evict_[set] = static_cast<std::uint8_t>((slot & 1) ^ 1);  // the other way goes next
    last_block_ = block;
    last_data_ = data_.get() + slot * kBlockBytes;
    return last_data_ + byte % kBlockBytes;
  }
  int fd_;
  std::uint64_t mask_ = 0, misses_ = 0;
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint8_t> evict_;  // per set: the way a miss replaces
  std::uint64_t last_block_ = kEmpty;  // the block the last lookup found, at last_data_
  const std::byte* last_data_ = nullptr;
  std::unique_ptr<std::byte[]> data_;
  std::string error_;
};

}  // namespace gaussmesh::stream::detail
