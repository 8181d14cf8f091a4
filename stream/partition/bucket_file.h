// Records distributed into buckets on disk, for the external passes of the spatial renumbering
// (reorder.cpp): one temporary file of equal blocks, each bucket's records in blocks of its own,
// in the order they were appended. One file and one buffer per bucket, whatever the bucket
// count, so the memory is the buckets' buffers and the block numbers (4 bytes a block), and no
// descriptor limit applies. A bucket's last block may be partly filled (the file has a hole
// there).
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "format/file_io.h"
#include "format/status.h"
#include "stream/partition/posix_io.h"

namespace gaussmesh::stream::detail {

class BucketFile {
 public:
  BucketFile() = default;
  BucketFile(const BucketFile&) = delete;
  BucketFile& operator=(const BucketFile&) = delete;
  ~BucketFile() { remove(); }

  // `record_bytes` divides every block; a bucket's buffer holds about buffer_bytes (at least 64
  // records).
  format::Status open(const std::string& path, std::size_t buckets, std::size_t record_bytes, std::size_t buffer_bytes) {
    path_ = path;
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd_ < 0) return format::Status::error(format::Code::kOutput, path, "cannot create temporary file: " + errno_text());
    block_ = std::max<std::size_t>(buffer_bytes / record_bytes, 64) * record_bytes;
    buffers_.clear();
    buffers_.resize(buckets);
    used_.assign(buckets, 0);
    blocks_.assign(buckets, {});
    last_bytes_.assign(buckets, 0);
    return {};
  }
  std::size_t buckets() const { return buffers_.size(); }
  std::uint64_t bytes() const { return written_; }
  // The bytes appended to `bucket` (after finish()).
  std::uint64_t bucket_bytes(std::size_t bucket) const {
    const std::size_t n = blocks_[bucket].size();
    return n == 0 ? 0 : (n - 1) * std::uint64_t{block_} + block_size(bucket, n - 1);
  }

  // One record of the size given to open().
  template <class Record>
  format::Status append(std::size_t bucket, const Record& record) {
    if (!buffers_[bucket]) buffers_[bucket].reset(new std::byte[block_]);
    std::memcpy(buffers_[bucket].get() + used_[bucket], &record, sizeof(Record));
    used_[bucket] += sizeof(Record);
    if (used_[bucket] == block_) return flush(bucket);
    return {};
  }
  // Writes out what the buffers hold and frees them.
  format::Status finish() {
    for (std::size_t b = 0; b < buffers_.size(); ++b) {
      GM_RETURN_IF_ERROR(flush(b));
      buffers_[b].reset();
    }
    return {};
  }
  // Calls fn(bytes) for each block of `bucket`, in order (finish() first).
  template <class Fn>
  format::Status read(std::size_t bucket, Fn&& fn) {
    std::vector<std::byte> buffer(block_);
    for (std::size_t i = 0; i < blocks_[bucket].size(); ++i) {
      GM_RETURN_IF_ERROR(read_block(bucket, i, buffer.data()));
      GM_RETURN_IF_ERROR(fn(std::span<const std::byte>(buffer.data(), block_size(bucket, i))));
    }
    return {};
  }
  // Reads every record of `bucket` (finish() first) into out, which holds bucket_bytes(bucket).
  format::Status read_all(std::size_t bucket, std::byte* out) {
    for (std::size_t i = 0; i < blocks_[bucket].size(); ++i) {
      GM_RETURN_IF_ERROR(read_block(bucket, i, out));
      out += block_size(bucket, i);
    }
    return {};
  }
  // Calls fn(bytes) for each block of `bucket`, in order (finish() first), and writes the block
  // back where it was: a pass that changes records in place writes over pages the page cache
  // already holds, and its output needs no second file.
  template <class Fn>
  format::Status rewrite(std::size_t bucket, Fn&& fn) {
    std::vector<std::byte> buffer(block_);
    for (std::size_t i = 0; i < blocks_[bucket].size(); ++i) {
      GM_RETURN_IF_ERROR(read_block(bucket, i, buffer.data()));
      const std::size_t size = block_size(bucket, i);
      GM_RETURN_IF_ERROR(fn(std::span<std::byte>(buffer.data(), size)));
      if (!format::write_all(fd_, buffer.data(), size, std::uint64_t{blocks_[bucket][i]} * block_, true)) {
        return format::Status::error(format::Code::kOutput, path_, "write failed: " + errno_text());
      }
    }
    return {};
  }

  // One bucket's records in order, pulled one at a time (finish() first): a pass that merges
  // several buckets holds one block of each.
  template <class Record>
  class Cursor {
   public:
    Cursor(BucketFile& file, std::size_t bucket) : file_(&file), bucket_(bucket) {}
    // The next record; false at the bucket's end or on a read error (status() tells).
    bool next(Record& out) {
      if (at_ == end_ && !load()) return false;
      std::memcpy(&out, buffer_.data() + at_, sizeof(Record));
      at_ += sizeof(Record);
      return true;
    }
    const format::Status& status() const { return status_; }

   private:
    bool load() {
      if (!status_.is_ok() || block_ == file_->blocks_[bucket_].size()) return false;
      const std::size_t size = file_->block_size(bucket_, block_);
      buffer_.resize(file_->block_);
      status_ = file_->read_block(bucket_, block_, buffer_.data());
      if (!status_.is_ok()) return false;
      ++block_;
      at_ = 0;
      end_ = size / sizeof(Record) * sizeof(Record);
      return end_ > 0;
    }
    BucketFile* file_;
    std::size_t bucket_;
    std::size_t block_ = 0, at_ = 0, end_ = 0;
    std::vector<std::byte> buffer_;
    format::Status status_;
  };

  // Closes and deletes the file, and frees the block lists (idempotent).
  void remove() {
    std::vector<std::vector<std::uint32_t>>().swap(blocks_);
    if (fd_ < 0) return;
    ::close(fd_);
    ::unlink(path_.c_str());
    fd_ = -1;
  }

 private:
  // The bytes of block i of `bucket`: the last one may be partly filled.
  std::size_t block_size(std::size_t bucket, std::size_t i) const {
    return i + 1 == blocks_[bucket].size() && last_bytes_[bucket] > 0 ? last_bytes_[bucket] : block_;
  }
  // Block i of `bucket` into out (block_size bytes).
  format::Status read_block(std::size_t bucket, std::size_t i, std::byte* out) {
    const std::size_t size = block_size(bucket, i);
    if (read_some(fd_, out, size, std::uint64_t{blocks_[bucket][i]} * block_) != static_cast<std::int64_t>(size)) {
      return format::Status::error(format::Code::kBadInput, path_, "temporary file is shorter than written");
    }
    return {};
  }
  // Writes the bucket's buffer as the file's next block (a partial one only from finish()).
  format::Status flush(std::size_t bucket) {
    const std::size_t size = used_[bucket];
    if (size == 0) return {};
    if (end_ / block_ >= UINT32_MAX) return format::Status::error(format::Code::kResources, path_, "more than 2^32 blocks");
    if (!format::write_all(fd_, buffers_[bucket].get(), size, end_, true)) {
      return format::Status::error(format::Code::kOutput, path_, "write failed: " + errno_text());
    }
    blocks_[bucket].push_back(static_cast<std::uint32_t>(end_ / block_));
    if (size < block_) last_bytes_[bucket] = size;
    end_ += block_;
    written_ += size;
    used_[bucket] = 0;
    return {};
  }

  int fd_ = -1;
  std::string path_;
  std::size_t block_ = 0;
  std::vector<std::unique_ptr<std::byte[]>> buffers_;
  std::vector<std::size_t> used_;
  std::vector<std::vector<std::uint32_t>> blocks_;  // per bucket: its blocks' numbers
  std::vector<std::size_t> last_bytes_;               // per bucket: its partial last block's bytes, or 0
  std::uint64_t end_ = 0, written_ = 0;
};

}  // namespace gaussmesh::stream::detail
