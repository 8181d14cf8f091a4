// The face spill: the ingest pass writes the faces in input order to one compressed record file; every
// later scan reads it back, a frame ahead on a thread of its own.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "format/mesh_types.h"
#include "format/record_file.h"
#include "format/status.h"
#include "stream/core/thread_status.h"

namespace gaussmesh::stream::detail {

using format::Status;
using format::Triangle;

// The face spill: faces in input order as a record file (kFaceSpillRecordKind) with column frames,
// the three vertex ids as differences from the previous face's. Neighbouring faces share
// vertices, so the ids compress to a few percent of plain triangles: temporary files are slow to
// write, and the scans read the spill once per ring round and once more for the chunks.
constexpr std::uint32_t kFaceSpillRecordKind = 0x53464D47u;  // "GMFS"
constexpr std::size_t kFaceSpillFrameBytes = std::size_t{1} << 20;

// zstd levels. The input's spill: -1, on these frames markedly faster than level 1 both ways,
// for a spill a little larger. The renumbered spill (sorted by lowest corner, ids in spatial
// order) compresses far less than an ordered input's: there the fastest level costs less to
// write and to read back than the bytes it saves (docs/partition.md, "The renumbered spill's
// zstd level").
constexpr int kFaceSpillLevel = -1;
constexpr int kRenumberedSpillLevel = -1000;

class FaceSpill {
 public:
  Status open(const std::string& path, int level = kFaceSpillLevel) {
    format::RecordWriterOptions options;
    options.frame_bytes = kFaceSpillFrameBytes;
    options.level = level;
    options.columns = {{4, true}, {4, true}, {4, true}};
    auto writer = format::RecordWriter::create(path, kFaceSpillRecordKind, sizeof(Triangle), options);
    if (!writer) return writer.status();
    writer_ = std::move(*writer);
    return {};
  }
  Status write(std::span<const Triangle> batch) { return writer_->append(std::as_bytes(batch)); }
  Status close() { return writer_->finish(); }
  std::uint64_t bytes() const { return writer_ ? writer_->bytes_written() : 0; }

 private:
  std::unique_ptr<format::RecordWriter> writer_;
};

// Reads the frames of a face spill, one frame ahead of the caller on its own thread when
// `ahead` (a run of --threads 1 reads in the caller's thread).
class FrameReadAhead {
 public:
  // tag(faces, tags), when set, fills one tag per face of a frame, on the read-ahead thread when
  // there is one (PartitionRun::scan_faces), before the frame is handed over; its error is the
  // frame's.
  using Tagger = std::function<Status(const std::vector<Triangle>&, std::vector<std::uint32_t>&)>;
  // skip(frame) true: the frame is passed over undecompressed (RecordReader::skip); called on
  // the read-ahead thread, in frame order.
  using Skip = std::function<bool(std::size_t)>;
  FrameReadAhead(format::RecordReader& reader, Tagger tag, Skip skip, bool ahead)
      : reader_(reader), tag_(std::move(tag)), skip_(std::move(skip)) {
    if (ahead) thread_ = std::thread([this] { run(); });
  }
  ~FrameReadAhead() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }
  FrameReadAhead(const FrameReadAhead&) = delete;
  FrameReadAhead& operator=(const FrameReadAhead&) = delete;
  // The next frame's faces and their tags into out, or, for a skipped frame, none and its
  // record count in skipped; both empty at the end. Or the reader's error.
  Status next(std::vector<Triangle>& out, std::vector<std::uint32_t>& tags, std::uint64_t& skipped) {
    if (!thread_.joinable()) return read(out, tags, skipped);
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return full_; });
    out.swap(ready_);
    tags.swap(ready_tags_);
    skipped = ready_skipped_;
    Status status = status_;
    full_ = false;
    changed_.notify_all();
    return status;
  }

 private:
  // Frames are all the same size but the last: resize keeps the buffer (and fills nothing).
  Status read(std::vector<Triangle>& frame, std::vector<std::uint32_t>& tags, std::uint64_t& skipped) {
    skipped = 0;
    if (skip_(frame_++)) {
      auto passed = reader_.skip();
      frame.clear();
      if (!passed) return passed.status();
      skipped = *passed;
      return {};
    }
    auto got = reader_.next();
    if (!got) {
      frame.clear();
      return got.status();
    }
    frame.resize(got->size() / sizeof(Triangle));
    if (!got->empty()) std::memcpy(frame.data(), got->data(), got->size());
    if (!tag_) return {};
    tags.resize(frame.size());
    return tag_(frame, tags);
  }
  void run() {
    std::vector<Triangle> frame;
    std::vector<std::uint32_t> tags;
    for (bool more = true; more;) {
      std::uint64_t skipped = 0;
      Status status = status_of_work("face spill", [&] { return read(frame, tags, skipped); });
      more = status.is_ok() && (!frame.empty() || skipped > 0);
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return !full_ || stopping_; });
      if (stopping_) return;
      ready_.swap(frame);
      ready_tags_.swap(tags);
      ready_skipped_ = skipped;
      status_ = status;
      full_ = true;
      changed_.notify_all();
    }
  }

  format::RecordReader& reader_;
  Tagger tag_;
  Skip skip_;
  std::size_t frame_ = 0;  // the reading side's next frame
  std::uint64_t ready_skipped_ = 0;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Triangle> ready_;
  std::vector<std::uint32_t> ready_tags_;
  Status status_;
  bool full_ = false, stopping_ = false;
  std::thread thread_;  // last: starts once the rest is built (none when not reading ahead)
};

}  // namespace gaussmesh::stream::detail
