// Sequential scans of the vertex positions (the position files, or the input's own records), in
// batches read and handled piece by piece on the caller's threads.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>

#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/partition/chunk_partition.h"
#include "stream/partition/input_positions.h"
#include "stream/partition/posix_io.h"

namespace gaussmesh::stream::detail {

using format::Code;
using format::Status;
using format::Vec3f;

// One batch of a position scan: `want` records of `stride` bytes from byte `offset` of fd, read
// piece by piece on the pieces' threads (pieces(n, fn) calls fn(begin, end) over [0, n)), each
// piece's records into `records` (or, bare x, y, z records, straight into `out`) and converted
// there, then piece(begin, end) runs on them. Each piece reads its own records so that the
// kernel's copy out of the page cache runs on every thread instead of being the scan's serial
// part. A failed or short read is the first failing piece's `fail(offset, got)`.
template <class Pieces, class Piece, class Fail>
Status read_position_batch(int fd, std::uint64_t offset, std::size_t want, std::size_t stride, const VertexFiles::InputPositions* in,
                           std::byte* records, Vec3f* out, Pieces&& pieces, Piece&& piece, Fail&& fail) {
  std::mutex mutex;
  std::size_t failed_at = want;
  Status failed;
  pieces(want, [&](std::size_t begin, std::size_t end) {
    void* target = records != nullptr ? static_cast<void*>(records + begin * stride) : static_cast<void*>(out + begin);
    const std::uint64_t at = offset + begin * stride;
    const std::int64_t got = read_some(fd, target, (end - begin) * stride, at);
    if (got != static_cast<std::int64_t>((end - begin) * stride)) {
      std::lock_guard<std::mutex> lock(mutex);
      if (begin < failed_at) {
        failed_at = begin;
        failed = fail(at, got);
      }
      return;
    }
    if (records != nullptr)
      for (std::size_t i = begin; i < end; ++i) out[i] = input_position(*in, records + i * stride);
    piece(begin, end);
  });
  return failed;
}

// scan_positions from the input's own records: batches of at most 768 KiB of records.
template <class Pieces, class Piece, class Batch>
Status scan_input_positions(const VertexFiles::InputPositions& in, std::uint64_t expected, Pieces&& pieces, Piece&& piece,
                            Batch&& batch) {
  auto opened = open_input_positions(in);
  if (!opened) return opened.status();
  FdCloser closer{*opened};
  // Records of x, y, z alone are read straight into the positions.
  const bool bare = in.stride == sizeof(Vec3f) && in.xyz[0] == 0 && in.xyz[1] == 4 && in.xyz[2] == 8;
  // At most a stripe's vertices a batch, as from the position files (the owner pass's buffer
  // holds a stripe).
  const std::size_t per_batch = std::clamp<std::size_t>(kPositionStripeVertices * sizeof(Vec3f) / in.stride, 1, kPositionStripeVertices);
  std::unique_ptr<std::byte[]> records(bare ? nullptr : new std::byte[per_batch * in.stride]);
  std::unique_ptr<Vec3f[]> buffer(new Vec3f[per_batch]);
  for (std::uint64_t done = 0; done < expected;) {
    const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(per_batch, expected - done));
    const std::span<const Vec3f> positions(buffer.get(), want);
    GM_RETURN_IF_ERROR(read_position_batch(
        *opened, in.first_byte + done * in.stride, want, in.stride, &in, records.get(), buffer.get(), pieces,
        [&](std::size_t begin, std::size_t end) { piece(done, positions, begin, end); },
        [&](std::uint64_t at, std::int64_t got) {
          return Status::error(Code::kBadInput, in.path + ": byte " + std::to_string(at),
                               got < 0 ? "read failed: " + errno_text() : "the input changed during the run");
        }));
    GM_RETURN_IF_ERROR(batch(done, positions));
    done += want;
  }
  return {};
}

// Reads the positions of vertices 0 .. expected - 1 in order, a stripe (768 KiB) at a time
// from the two position files, or from the input's records (VertexFiles::input). Each batch is
// read and handled in pieces (pieces(n, fn), fn(begin, end)): piece(first_index, batch, begin,
// end) once its piece is read, then batch(first_index, batch) once all are. The buffer stays
// small: a larger one, once freed, raises glibc's mmap threshold, and later buffers of that size
// come from the heap and stay resident, raising the run's peak.
template <class Pieces, class Piece, class Batch>
Status scan_positions(const VertexFiles& files, std::uint64_t expected, Pieces&& pieces, Piece&& piece, Batch&& batch) {
  if (files.input) return scan_input_positions(*files.input, expected, pieces, piece, batch);
  int fds[kPositionFiles];
  for (std::uint32_t i = 0; i < kPositionFiles; ++i) fds[i] = -1;
  struct Closer {
    int* fds;
    ~Closer() {
      for (std::uint32_t i = 0; i < kPositionFiles; ++i)
        if (fds[i] >= 0) ::close(fds[i]);
    }
  } closer{fds};
  for (std::uint32_t i = 0; i < kPositionFiles; ++i) {
    fds[i] = ::open(files.positions[i].c_str(), O_RDONLY | O_CLOEXEC);
    if (fds[i] < 0) return Status::error(Code::kBadInput, files.positions[i], "cannot open temporary file: " + errno_text());
  }
  std::unique_ptr<Vec3f[]> buffer(new Vec3f[kPositionStripeVertices]);
  for (std::uint64_t done = 0; done < expected;) {
    const auto v = static_cast<std::uint32_t>(done);
    const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(kPositionStripeVertices, expected - done));
    const std::uint32_t file = position_file(v);
    const std::span<const Vec3f> positions(buffer.get(), want);
    GM_RETURN_IF_ERROR(read_position_batch(
        fds[file], position_record(v) * sizeof(Vec3f), want, sizeof(Vec3f), nullptr, nullptr, buffer.get(), pieces,
        [&](std::size_t begin, std::size_t end) { piece(done, positions, begin, end); },
        [&](std::uint64_t at, std::int64_t got) {
          return Status::error(Code::kBadInput, files.positions[file] + ": byte " + std::to_string(at),
                               got < 0 ? "read failed: " + errno_text() : "temporary file is shorter than written");
        }));
    GM_RETURN_IF_ERROR(batch(done, positions));
    done += want;
  }
  return {};
}

}  // namespace gaussmesh::stream::detail
