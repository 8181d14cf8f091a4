// Record files between the out-of-core passes: fixed-size records in independent zstd frames
// (content checksums on), a versioned header and a seek table at the end, modelled on zstd's
// seekable format. docs/records.md gives the byte layout. Everything read back is untrusted:
// every size is bounds-checked before it is used, and a damaged file is a kBadInput error
// naming the file, the frame and the byte offset.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "format/status.h"

namespace gaussmesh::format {

inline constexpr std::uint32_t kRecordFileVersion = 2;
// Largest uncompressed frame; writers cut frames at whole records below it.
inline constexpr std::size_t kMaxRecordFrameBytes = std::size_t{4} << 20;

// A zstd compression context and its output buffer, shared by many RecordWriters so that
// hundreds of writers open at once cost only their pending frames (a context is ~1 MB).
// Not thread-safe: the writers sharing one are used from one thread at a time.
class RecordCompressor {
 public:
  // level is zstd's (1 = fast; negative levels are faster still).
  static Result<std::unique_ptr<RecordCompressor>> create(int level = 1);
  ~RecordCompressor();
  RecordCompressor(const RecordCompressor&) = delete;
  RecordCompressor& operator=(const RecordCompressor&) = delete;

 private:
  friend class RecordWriter;
  RecordCompressor() = default;
  void* cctx_ = nullptr;  // ZSTD_CCtx
  std::vector<std::byte> buffer_, columns_;
};

// One field of a record, for files whose frames are stored column by column (docs/records.md):
// the field's bytes of every record of the frame together, a 4- or 8-byte integer field with
// `delta` as the difference from the previous record's (wrapping; the first from zero). Ids that
// run nearly in order become runs of small numbers that zstd compresses several times faster,
// and smaller, than the interleaved records. Readers need not know: the file's header says.
struct RecordField {
  std::uint8_t bytes = 0;  // 1..127
  bool delta = false;      // only for 4 or 8 bytes
};
inline constexpr std::size_t kMaxRecordFields = 11;

struct RecordWriterOptions {
  // zstd level of the writer's own context. -4: on the out-of-core passes' column frames it is
  // several times faster than level 1 both ways, for a few percent more bytes (docs/records.md).
  int level = -4;
  std::size_t frame_bytes = std::size_t{1} << 20;  // frames are cut at whole records below this
  RecordCompressor* shared = nullptr;          // if set: used instead of an own context (not owned)
  // false: no descriptor is held between frames; the file is reopened (append) for each frame
  // and closed after it, so thousands of writers fit under the open-file limit.
  bool keep_open = true;
  // Empty: frames hold the records as they are. Else the record's fields in order, their bytes
  // summing to the record size, at most kMaxRecordFields (kProcessing at create if not).
  std::vector<RecordField> columns;
};

// Where one record file lies inside a RecordSegmentFile: its first byte and its length.
struct RecordSegment {
  std::uint64_t offset = 0;
  std::uint64_t bytes = 0;
};

// A file of record files back to back ("segments"), for a pass that writes many small record
// files: one file is created instead of one per record file. Creating a file costs far more
// than appending to an open one, and such a pass writes several record files per chunk
// (docs/records.md, "Segment files").
// Each segment is a whole record file, byte for byte, at an offset: RecordWriter::create_in
// appends one and RecordReader::open(path, ..., segment) reads one. One writer at a time. The
// file is closed on destruction and left in place, as record files are; its directory's owner
// removes it.
class RecordSegmentFile {
 public:
  // Creates path (truncating it). Errors: kOutput.
  static Result<std::unique_ptr<RecordSegmentFile>> create(const std::string& path);
  ~RecordSegmentFile();
  RecordSegmentFile(const RecordSegmentFile&) = delete;
  RecordSegmentFile& operator=(const RecordSegmentFile&) = delete;

  const std::string& path() const { return path_; }
  std::uint64_t size() const { return end_; }  // bytes of the finished segments

 private:
  friend class RecordWriter;
  RecordSegmentFile() = default;
  int fd_ = -1;
  std::string path_;
  std::uint64_t end_ = 0;
  bool writing_ = false;  // a writer is appending a segment
};

// Segment files for many threads: a thread leases one, appends its segments, and gives it back;
// files are made on first need, so there are as many as were ever leased at once. Files are
// path_prefix + N + ".rec", N from 0. Thread-safe.
class RecordSegmentPool {
 public:
  explicit RecordSegmentPool(std::string path_prefix) : prefix_(std::move(path_prefix)) {}
  std::string path(std::uint32_t file) const { return prefix_ + std::to_string(file) + ".rec"; }

  // One file, this holder's alone until destroyed. Check status() first (kOutput when a new
  // file cannot be created).
  class Lease {
   public:
    explicit Lease(RecordSegmentPool& pool);
    ~Lease();
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    const Status& status() const { return status_; }
    std::uint32_t index() const { return index_; }
    RecordSegmentFile& file() { return *file_; }

   private:
    RecordSegmentPool& pool_;
    RecordSegmentFile* file_ = nullptr;
    std::uint32_t index_ = 0;
    Status status_;
  };

 private:
  std::string prefix_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<RecordSegmentFile>> files_;  // under mutex_; the files never move
  std::vector<std::uint32_t> free_;                         // under mutex_
};

class RecordWriter {
 public:
  // Creates path (truncating it). kind names what the records are (readers check it);
  // record_size in 1..kMaxRecordFrameBytes; level is zstd's (negative levels are faster).
  static Result<std::unique_ptr<RecordWriter>> create(const std::string& path, std::uint32_t kind,
                                                      std::uint32_t record_size, int level = -4,
                                                      std::size_t frame_bytes = std::size_t{1} << 20);
  // The same with every option; memory per writer is one pending frame (frame_bytes) plus, without
  // options.shared, a zstd context and a compressed-frame buffer.
  static Result<std::unique_ptr<RecordWriter>> create(const std::string& path, std::uint32_t kind,
                                                      std::uint32_t record_size, const RecordWriterOptions& options);
  // The same, appended to `file` as its next segment: options.keep_open is ignored, the rest
  // applies. The writer must not outlive `file`, and no other writer may be appending to it
  // (kProcessing if one is). A writer destroyed unfinished leaves no segment: the next one
  // overwrites its bytes.
  static Result<std::unique_ptr<RecordWriter>> create_in(RecordSegmentFile& file, std::uint32_t kind,
                                                         std::uint32_t record_size, const RecordWriterOptions& options = {});
  ~RecordWriter();
  RecordWriter(const RecordWriter&) = delete;
  RecordWriter& operator=(const RecordWriter&) = delete;

  // Appends whole records: bytes.size() must be a multiple of record_size (kProcessing if not).
  // Whole frames handed over when nothing is pending are compressed in place, never copied.
  Status append(std::span<const std::byte> bytes);
  // Bytes per frame, a whole number of records (options.frame_bytes rounded down).
  std::size_t frame_limit() const { return frame_limit_; }
  // Writes the last frame and the seek table, and closes the file. Required for a valid file.
  Status finish();
  std::uint64_t records() const { return records_; }
  std::uint64_t bytes_written() const { return file_bytes_; }  // compressed, on disk
  // Where the record file lies in its segment file (create_in), once finished.
  RecordSegment segment() const { return {base_, file_bytes_}; }

 private:
  RecordWriter() = default;
  static Result<std::unique_ptr<RecordWriter>> make(const std::string& path, std::uint32_t kind, std::uint32_t record_size,
                                                    const RecordWriterOptions& options, RecordSegmentFile* segment_file);
  Status flush_frame();
  Status write_frame(std::span<const std::byte> plain);
  Status write_raw(const void* data, std::size_t size);
  Status reopen();
  Status close_file();

  int fd_ = -1;
  std::string path_;
  std::uint32_t record_size_ = 0;
  std::size_t frame_limit_ = 0;
  void* cctx_ = nullptr;  // ZSTD_CCtx, owned unless shared_
  RecordCompressor* shared_ = nullptr;
  RecordSegmentFile* segment_file_ = nullptr;  // set: fd_ is its descriptor, bytes go at base_ + offset
  std::uint64_t base_ = 0;
  bool keep_open_ = true;
  std::vector<RecordField> columns_;
  std::vector<std::byte> pending_, compressed_, column_buffer_;
  // Offsets of the first frames; beyond kOffsetsInMemory frames finish() finds them again from
  // the frames' own headers, so a writer's memory does not grow with its file.
  std::vector<std::uint64_t> frame_offsets_;
  std::uint64_t frames_ = 0;
  std::uint64_t records_ = 0, file_bytes_ = 0;
  bool finished_ = false, failed_ = false;
};

class RecordReader {
 public:
  // Opens path and checks header, version, kind, record size and seek table.
  static Result<std::unique_ptr<RecordReader>> open(const std::string& path, std::uint32_t kind,
                                                    std::uint32_t record_size);
  // The same for the record file at `segment` of path (a RecordSegmentFile); offsets in its
  // errors are the file's. A segment past the end of the file is kBadInput.
  static Result<std::unique_ptr<RecordReader>> open(const std::string& path, std::uint32_t kind, std::uint32_t record_size,
                                                    RecordSegment segment);
  ~RecordReader();
  RecordReader(const RecordReader&) = delete;
  RecordReader& operator=(const RecordReader&) = delete;

  std::size_t frame_count() const { return frame_offsets_.size(); }
  std::uint64_t records() const { return records_; }
  // Decompresses the next frame's records into a reused buffer; an empty span at the end.
  // The span is valid until the next call. At the end, frames that held other than the records
  // the seek table claims are kBadInput.
  Result<std::span<const std::byte>> next();
  // Passes over the next frame without decompressing it (its header and the seek table are
  // checked, its checksum is not): how many records it holds, 0 at the end, with the same check
  // of the record count as next().
  Result<std::uint64_t> skip();

 private:
  struct FrameHeader {
    std::uint64_t at;
    const std::byte* bytes;  // the frame's bytes, header first (valid until the next fetch)
    std::uint64_t compressed, plain;
  };
  RecordReader() = default;
  // The next frame's header, checked against the seek table and the limits.
  Result<FrameHeader> frame_header();
  static Result<std::unique_ptr<RecordReader>> open_at(const std::string& path, std::uint32_t kind, std::uint32_t record_size,
                                                       const RecordSegment* segment);
  Status fail(std::uint64_t offset, const std::string& message) const;
  Status check_end() const;
  const std::byte* fetch(std::uint64_t at, std::uint64_t size);

  int fd_ = -1;
  std::string path_;
  std::uint32_t record_size_ = 0;
  void* dctx_ = nullptr;  // ZSTD_DCtx
  std::vector<RecordField> columns_;  // from the header; empty: records as they are
  std::vector<std::uint64_t> frame_offsets_;
  std::uint64_t base_ = 0;  // where the record file starts in the file (a segment's offset)
  std::uint64_t data_end_ = 0, records_ = 0, records_read_ = 0;
  std::size_t next_frame_ = 0;
  std::vector<std::byte> buffer_, plain_, column_buffer_;  // buffer_: file bytes from buffer_at_
  std::uint64_t buffer_at_ = 0;
};

}  // namespace gaussmesh::format
