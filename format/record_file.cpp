// Record files: fixed-size records in checksummed zstd frames with a trailing seek table.
#include "format/record_file.h"

#include "format/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <bit>
#include <cerrno>
#include <cstring>
#include <memory>

namespace gaussmesh::format {
namespace {

static_assert(std::endian::native == std::endian::little, "record files are little-endian");

constexpr char kMagic[8] = {'G', 'M', 'R', 'E', 'C', 'O', 'R', 'D'};
constexpr char kSeekMagic[8] = {'G', 'M', 'R', 'S', 'E', 'E', 'K', '1'};
constexpr std::size_t kHeaderBytes = 32;
constexpr std::size_t kFrameHeaderBytes = 8;
// Frame offsets a writer keeps; a file with more frames has them read back from its frame
// headers when the seek table is written (hundreds of writers open at once, each with many
// small frames, would otherwise hold 8 bytes per frame each until the end).
constexpr std::size_t kOffsetsInMemory = 256;
constexpr std::size_t kFooterBytes = 24;
constexpr std::uint64_t kReadAheadBytes = std::uint64_t{256} << 10;  // a reader's read buffer

template <class T>
void put(std::byte* at, T value) {
  std::memcpy(at, &value, sizeof value);
}
template <class T>
T get(const std::byte* at) {
  T value;
  std::memcpy(&value, at, sizeof value);
  return value;
}

std::string errno_text() { return std::strerror(errno); }

// Field descriptors in the header: byte 20 the count (0: records as they are), then one byte
// per field, its size in the low 7 bits and 0x80 for delta.
constexpr std::size_t kColumnsAt = 20;
static_assert(kColumnsAt + 1 + kMaxRecordFields == kHeaderBytes);

// Records of a frame (n of size record_size) into columns, integer fields as differences.
template <class T>
void delta_column(const std::byte* records, std::size_t n, std::size_t stride, std::byte* out) {
  T previous = 0;
  for (std::size_t i = 0; i < n; ++i) {
    T value;
    std::memcpy(&value, records + i * stride, sizeof value);
    const T d = static_cast<T>(value - previous);
    std::memcpy(out + i * sizeof(T), &d, sizeof d);
    previous = value;
  }
}
template <class T>
void undelta_column(const std::byte* column, std::size_t n, std::size_t stride, std::byte* records) {
  T value = 0;
  for (std::size_t i = 0; i < n; ++i) {
    T d;
    std::memcpy(&d, column + i * sizeof(T), sizeof d);
    value = static_cast<T>(value + d);
    std::memcpy(records + i * stride, &value, sizeof value);
  }
}
// A plain field's bytes from one layout to the other: n values, src_step and dst_step apart
// (the record size on the records' side, the field's size on the column's). The sizes records
// use are copied with a constant size, inlined: a memcpy call per record of a variable size
// would cost more than copying a small field (a 1-byte flag) itself.
template <std::size_t kBytes>
void copy_values(const std::byte* src, std::size_t src_step, std::byte* dst, std::size_t dst_step, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) std::memcpy(dst + i * dst_step, src + i * src_step, kBytes);
}
void copy_field(const std::byte* src, std::size_t src_step, std::byte* dst, std::size_t dst_step, std::size_t n,
                std::size_t bytes) {
  switch (bytes) {
    case 1: return copy_values<1>(src, src_step, dst, dst_step, n);
    case 4: return copy_values<4>(src, src_step, dst, dst_step, n);
    case 8: return copy_values<8>(src, src_step, dst, dst_step, n);
    default:
      for (std::size_t i = 0; i < n; ++i) std::memcpy(dst + i * dst_step, src + i * src_step, bytes);
  }
}
void to_columns(std::span<const RecordField> fields, std::span<const std::byte> records, std::size_t record_size,
                std::byte* out) {
  const std::size_t n = records.size() / record_size;
  std::size_t offset = 0;
  for (const RecordField& field : fields) {
    const std::byte* in = records.data() + offset;
    if (field.delta && field.bytes == 8) {
      delta_column<std::uint64_t>(in, n, record_size, out);
    } else if (field.delta) {
      delta_column<std::uint32_t>(in, n, record_size, out);
    } else {
      copy_field(in, record_size, out, field.bytes, n, field.bytes);
    }
    out += n * field.bytes;
    offset += field.bytes;
  }
}
void from_columns(std::span<const RecordField> fields, const std::byte* columns, std::size_t record_size,
                  std::span<std::byte> records) {
  const std::size_t n = records.size() / record_size;
  std::size_t offset = 0;
  for (const RecordField& field : fields) {
    std::byte* out = records.data() + offset;
    if (field.delta && field.bytes == 8) {
      undelta_column<std::uint64_t>(columns, n, record_size, out);
    } else if (field.delta) {
      undelta_column<std::uint32_t>(columns, n, record_size, out);
    } else {
      copy_field(columns, field.bytes, out, record_size, n, field.bytes);
    }
    columns += n * field.bytes;
    offset += field.bytes;
  }
}
// Why a field list is refused, or "" when it describes records of record_size bytes.
std::string check_columns(std::span<const RecordField> fields, std::size_t record_size) {
  if (fields.empty()) return "";
  if (fields.size() > kMaxRecordFields) return "more than " + std::to_string(kMaxRecordFields) + " fields";
  std::size_t sum = 0;
  for (const RecordField& field : fields) {
    if (field.bytes == 0 || field.bytes > 127) return "a field of " + std::to_string(field.bytes) + " bytes";
    if (field.delta && field.bytes != 4 && field.bytes != 8) return "a delta field of " + std::to_string(field.bytes) + " bytes";
    sum += field.bytes;
  }
  if (sum != record_size) return "fields of " + std::to_string(sum) + " bytes in a record of " + std::to_string(record_size);
  return "";
}


// One spare decompression context per thread: readers are opened per chunk and per pass, and a
// new context each time would allocate zstd's tables (~100 KB) again for every reader.
struct FreeDctx {
  void operator()(ZSTD_DCtx* dctx) const { ZSTD_freeDCtx(dctx); }
};
thread_local std::unique_ptr<ZSTD_DCtx, FreeDctx> spare_dctx;

ZSTD_DCtx* take_dctx() { return spare_dctx ? spare_dctx.release() : ZSTD_createDCtx(); }

void give_back_dctx(ZSTD_DCtx* dctx) {
  if (dctx == nullptr) return;
  if (spare_dctx) {
    ZSTD_freeDCtx(dctx);
    return;
  }
  ZSTD_DCtx_reset(dctx, ZSTD_reset_session_and_parameters);
  spare_dctx.reset(dctx);
}

}  // namespace

// ---------------------------------------------------------------------------------------------

Result<std::unique_ptr<RecordCompressor>> RecordCompressor::create(int level) {
  std::unique_ptr<RecordCompressor> compressor(new RecordCompressor());
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  if (cctx == nullptr) return Status::error(Code::kResources, "", "cannot create a zstd context");
  compressor->cctx_ = cctx;
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  return compressor;
}

RecordCompressor::~RecordCompressor() { ZSTD_freeCCtx(static_cast<ZSTD_CCtx*>(cctx_)); }

// ---------------------------------------------------------------------------------------------

Result<std::unique_ptr<RecordSegmentFile>> RecordSegmentFile::create(const std::string& path) {
  std::unique_ptr<RecordSegmentFile> file(new RecordSegmentFile());
  file->path_ = path;
  file->fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (file->fd_ < 0) return Status::error(Code::kOutput, path, "cannot create segment file: " + errno_text());
  return file;
}

RecordSegmentFile::~RecordSegmentFile() {
  if (fd_ >= 0) ::close(fd_);
}

RecordSegmentPool::Lease::Lease(RecordSegmentPool& pool) : pool_(pool) {
  std::lock_guard lock(pool.mutex_);
  if (!pool.free_.empty()) {
    index_ = pool.free_.back();
    pool.free_.pop_back();
  } else {
    index_ = static_cast<std::uint32_t>(pool.files_.size());
    auto created = RecordSegmentFile::create(pool.path(index_));
    if (!created) {
      status_ = created.status();
      return;
    }
    pool.files_.push_back(std::move(*created));
  }
  file_ = pool.files_[index_].get();
}

RecordSegmentPool::Lease::~Lease() {
  if (file_ == nullptr) return;
  std::lock_guard lock(pool_.mutex_);
  pool_.free_.push_back(index_);
}

// ---------------------------------------------------------------------------------------------

Result<std::unique_ptr<RecordWriter>> RecordWriter::create(const std::string& path, std::uint32_t kind,
                                                           std::uint32_t record_size, int level,
                                                           std::size_t frame_bytes) {
  RecordWriterOptions options;
  options.level = level;
  options.frame_bytes = frame_bytes;
  return create(path, kind, record_size, options);
}

Result<std::unique_ptr<RecordWriter>> RecordWriter::create(const std::string& path, std::uint32_t kind,
                                                           std::uint32_t record_size,
                                                           const RecordWriterOptions& options) {
  return make(path, kind, record_size, options, nullptr);
}

Result<std::unique_ptr<RecordWriter>> RecordWriter::create_in(RecordSegmentFile& file, std::uint32_t kind,
                                                              std::uint32_t record_size, const RecordWriterOptions& options) {
  if (file.writing_) return Status::error(Code::kProcessing, file.path_, "a second writer on a segment file");
  return make(file.path_, kind, record_size, options, &file);
}

Result<std::unique_ptr<RecordWriter>> RecordWriter::make(const std::string& path, std::uint32_t kind, std::uint32_t record_size,
                                                         const RecordWriterOptions& options, RecordSegmentFile* segment_file) {
  if (record_size == 0 || record_size > kMaxRecordFrameBytes) {
    return Status::error(Code::kProcessing, path, "record size " + std::to_string(record_size) + " out of range");
  }
  if (std::string why = check_columns(options.columns, record_size); !why.empty()) {
    return Status::error(Code::kProcessing, path, "record fields: " + why);
  }
  std::unique_ptr<RecordWriter> writer(new RecordWriter());
  writer->path_ = path;
  writer->columns_ = options.columns;
  writer->record_size_ = record_size;
  writer->shared_ = options.shared;
  writer->keep_open_ = options.keep_open || segment_file != nullptr;
  std::size_t limit = std::min(std::max<std::size_t>(options.frame_bytes, record_size), kMaxRecordFrameBytes);
  writer->frame_limit_ = limit - limit % record_size;
  if (segment_file != nullptr) {
    writer->segment_file_ = segment_file;
    writer->base_ = segment_file->end_;
    writer->fd_ = segment_file->fd_;
    segment_file->writing_ = true;
  } else {
    writer->fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (writer->fd_ < 0) return Status::error(Code::kOutput, path, "cannot create record file: " + errno_text());
  }
  if (writer->shared_ == nullptr) {
    ZSTD_CCtx* cctx = ZSTD_createCCtx();
    if (cctx == nullptr) return Status::error(Code::kResources, path, "cannot create a zstd context");
    writer->cctx_ = cctx;
    ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, options.level);
    ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  }
  // pending_ grows on demand: a writer fed whole frames (the partition's chunk writers, thousands
  // of them open at once) never touches it but for its last partial frame.
  std::byte header[kHeaderBytes] = {};
  std::memcpy(header, kMagic, sizeof kMagic);
  put<std::uint32_t>(header + 8, kRecordFileVersion);
  put<std::uint32_t>(header + 12, kind);
  put<std::uint32_t>(header + 16, record_size);
  header[kColumnsAt] = static_cast<std::byte>(options.columns.size());
  for (std::size_t i = 0; i < options.columns.size(); ++i) {
    header[kColumnsAt + 1 + i] = static_cast<std::byte>(options.columns[i].bytes | (options.columns[i].delta ? 0x80 : 0));
  }
  GM_RETURN_IF_ERROR(writer->write_raw(header, sizeof header));
  if (!writer->keep_open_) GM_RETURN_IF_ERROR(writer->close_file());
  return writer;
}

RecordWriter::~RecordWriter() {
  if (segment_file_ != nullptr) {
    if (fd_ >= 0) segment_file_->writing_ = false;  // unfinished: no segment, its bytes get overwritten
  } else if (fd_ >= 0) {
    ::close(fd_);
  }
  ZSTD_freeCCtx(static_cast<ZSTD_CCtx*>(cctx_));
}

Status RecordWriter::reopen() {
  if (fd_ >= 0) return {};
  fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (fd_ < 0) {
    failed_ = true;
    return Status::error(Code::kOutput, path_, "cannot reopen record file: " + errno_text());
  }
  return {};
}

Status RecordWriter::close_file() {
  if (fd_ < 0) return {};
  if (segment_file_ != nullptr) {  // the descriptor is the segment file's; this segment is done
    fd_ = -1;
    segment_file_->end_ = base_ + file_bytes_;
    segment_file_->writing_ = false;
    return {};
  }
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    failed_ = true;
    return Status::error(Code::kOutput, path_, "close failed: " + errno_text());
  }
  return {};
}

Status RecordWriter::write_raw(const void* data, std::size_t size) {
  if (!write_all(fd_, data, size, base_ + file_bytes_, segment_file_ != nullptr)) {
    failed_ = true;
    return Status::error(Code::kOutput, path_, "write failed: " + errno_text());
  }
  file_bytes_ += size;
  return {};
}

Status RecordWriter::write_frame(std::span<const std::byte> plain) {
  ZSTD_CCtx* cctx = static_cast<ZSTD_CCtx*>(shared_ != nullptr ? shared_->cctx_ : cctx_);
  std::vector<std::byte>& compressed = shared_ != nullptr ? shared_->buffer_ : compressed_;
  compressed.resize(kFrameHeaderBytes + ZSTD_compressBound(plain.size()));
  std::span<const std::byte> input = plain;
  if (!columns_.empty()) {
    std::vector<std::byte>& columns = shared_ != nullptr ? shared_->columns_ : column_buffer_;
    columns.resize(plain.size());
    to_columns(columns_, plain, record_size_, columns.data());
    input = columns;
  }
  std::size_t size = ZSTD_compress2(cctx, compressed.data() + kFrameHeaderBytes, compressed.size() - kFrameHeaderBytes,
                                    input.data(), input.size());
  if (ZSTD_isError(size)) {
    failed_ = true;
    return Status::error(Code::kProcessing, path_, std::string("zstd: ") + ZSTD_getErrorName(size));
  }
  put<std::uint32_t>(compressed.data(), static_cast<std::uint32_t>(size));
  put<std::uint32_t>(compressed.data() + 4, static_cast<std::uint32_t>(plain.size()));
  if (frames_++ < kOffsetsInMemory) frame_offsets_.push_back(file_bytes_);
  GM_RETURN_IF_ERROR(reopen());
  GM_RETURN_IF_ERROR(write_raw(compressed.data(), kFrameHeaderBytes + size));
  if (!keep_open_) GM_RETURN_IF_ERROR(close_file());
  return {};
}

Status RecordWriter::flush_frame() {
  if (pending_.empty()) return {};
  GM_RETURN_IF_ERROR(write_frame(pending_));
  pending_.clear();
  return {};
}

Status RecordWriter::append(std::span<const std::byte> bytes) {
  if (failed_ || finished_) return Status::error(Code::kProcessing, path_, "append after finish or failure");
  if (bytes.size() % record_size_ != 0) {
    return Status::error(Code::kProcessing, path_, "append of a partial record");
  }
  records_ += bytes.size() / record_size_;
  while (!bytes.empty()) {
    if (pending_.empty() && bytes.size() >= frame_limit_) {
      // A whole frame: compressed straight from the caller's bytes, never copied.
      GM_RETURN_IF_ERROR(write_frame(bytes.first(frame_limit_)));
      bytes = bytes.subspan(frame_limit_);
      continue;
    }
    std::size_t room = frame_limit_ - pending_.size();
    std::size_t take = std::min(room, bytes.size());
    pending_.insert(pending_.end(), bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(take));
    bytes = bytes.subspan(take);
    if (pending_.size() == frame_limit_) GM_RETURN_IF_ERROR(flush_frame());
  }
  return {};
}

Status RecordWriter::finish() {
  if (finished_) return {};
  GM_RETURN_IF_ERROR(flush_frame());
  if (frames_ > 0xFFFFFFFFu) return Status::error(Code::kResources, path_, "more than 2^32 - 1 frames");
  GM_RETURN_IF_ERROR(reopen());
  // The seek table, a block at a time: the kept offsets, then the rest found by walking the
  // frame headers from the last kept one.
  std::vector<std::byte> block;
  block.reserve(8 * kOffsetsInMemory);
  for (std::uint64_t offset : frame_offsets_) {
    block.resize(block.size() + 8);
    put<std::uint64_t>(block.data() + block.size() - 8, offset);
  }
  if (frames_ > frame_offsets_.size()) {
    const int in = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
    if (in < 0) return Status::error(Code::kOutput, path_, "cannot read back frame headers: " + errno_text());
    std::uint64_t at = frame_offsets_.back();
    for (std::uint64_t k = frame_offsets_.size(); k < frames_; ++k) {
      std::byte header[kFrameHeaderBytes];
      if (!pread_all(in, header, sizeof header, base_ + at)) {
        ::close(in);
        failed_ = true;
        return Status::error(Code::kOutput, path_, "cannot read back frame headers: " + errno_text());
      }
      at += kFrameHeaderBytes + get<std::uint32_t>(header);
      block.resize(block.size() + 8);
      put<std::uint64_t>(block.data() + block.size() - 8, at);
      if (block.size() >= 8 * kOffsetsInMemory) {
        Status st = write_raw(block.data(), block.size());
        if (!st.is_ok()) {
          ::close(in);
          return st;
        }
        block.clear();
      }
    }
    ::close(in);
  }
  std::byte footer[kFooterBytes] = {};
  put<std::uint64_t>(footer, records_);
  put<std::uint32_t>(footer + 8, static_cast<std::uint32_t>(frames_));
  put<std::uint32_t>(footer + 12, 0);
  std::memcpy(footer + 16, kSeekMagic, sizeof kSeekMagic);
  block.insert(block.end(), footer, footer + kFooterBytes);
  GM_RETURN_IF_ERROR(write_raw(block.data(), block.size()));
  GM_RETURN_IF_ERROR(close_file());
  finished_ = true;
  std::vector<std::byte>().swap(pending_);
  std::vector<std::byte>().swap(compressed_);
  std::vector<std::byte>().swap(column_buffer_);
  return {};
}

// ---------------------------------------------------------------------------------------------

Status RecordReader::fail(std::uint64_t offset, const std::string& message) const {
  return Status::error(Code::kBadInput, path_ + ": byte " + std::to_string(base_ + offset), message);
}

Result<std::unique_ptr<RecordReader>> RecordReader::open(const std::string& path, std::uint32_t kind,
                                                         std::uint32_t record_size) {
  return open_at(path, kind, record_size, nullptr);
}

Result<std::unique_ptr<RecordReader>> RecordReader::open(const std::string& path, std::uint32_t kind,
                                                         std::uint32_t record_size, RecordSegment segment) {
  return open_at(path, kind, record_size, &segment);
}

Result<std::unique_ptr<RecordReader>> RecordReader::open_at(const std::string& path, std::uint32_t kind,
                                                            std::uint32_t record_size, const RecordSegment* segment) {
  std::unique_ptr<RecordReader> reader(new RecordReader());
  reader->path_ = path;
  reader->record_size_ = record_size;
  reader->fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (reader->fd_ < 0) return Status::error(Code::kBadInput, path, "cannot open record file: " + errno_text());
  struct stat st {};
  if (::fstat(reader->fd_, &st) != 0) return Status::error(Code::kBadInput, path, "cannot stat: " + errno_text());
  auto size = static_cast<std::uint64_t>(st.st_size);
  if (segment != nullptr) {
    if (segment->offset > size || segment->bytes > size - segment->offset) {
      return reader->fail(segment->offset, "segment of " + std::to_string(segment->bytes) + " bytes runs past the end of the file (" +
                                               std::to_string(size) + " bytes)");
    }
    reader->base_ = segment->offset;
    size = segment->bytes;
  }
  if (size < kHeaderBytes + kFooterBytes) return reader->fail(0, "record file too short (" + std::to_string(size) + " bytes)");
  std::byte header[kHeaderBytes];
  if (!pread_all(reader->fd_, header, sizeof header, reader->base_)) return reader->fail(0, "cannot read header");
  if (std::memcmp(header, kMagic, sizeof kMagic) != 0) return reader->fail(0, "not a gaussmesh record file");
  if (get<std::uint32_t>(header + 8) != kRecordFileVersion) {
    return reader->fail(8, "record file version " + std::to_string(get<std::uint32_t>(header + 8)) +
                               ", expected " + std::to_string(kRecordFileVersion));
  }
  if (get<std::uint32_t>(header + 12) != kind) return reader->fail(12, "record kind " + std::to_string(get<std::uint32_t>(header + 12)) + ", expected " + std::to_string(kind));
  if (get<std::uint32_t>(header + 16) != record_size) return reader->fail(16, "record size " + std::to_string(get<std::uint32_t>(header + 16)) + ", expected " + std::to_string(record_size));
  const std::size_t fields = std::to_integer<std::size_t>(header[kColumnsAt]);
  if (fields > kMaxRecordFields) return reader->fail(kColumnsAt, std::to_string(fields) + " record fields, at most " + std::to_string(kMaxRecordFields));
  for (std::size_t i = 0; i < fields; ++i) {
    const unsigned code = std::to_integer<unsigned>(header[kColumnsAt + 1 + i]);
    reader->columns_.push_back({static_cast<std::uint8_t>(code & 0x7F), (code & 0x80) != 0});
  }
  if (std::string why = check_columns(reader->columns_, record_size); !why.empty()) return reader->fail(kColumnsAt, "record fields: " + why);
  std::byte footer[kFooterBytes];
  const std::uint64_t footer_at = size - kFooterBytes;
  if (!pread_all(reader->fd_, footer, sizeof footer, reader->base_ + footer_at)) return reader->fail(footer_at, "cannot read seek table");
  if (std::memcmp(footer + 16, kSeekMagic, sizeof kSeekMagic) != 0) {
    return reader->fail(footer_at, "seek table missing (file truncated or not finished)");
  }
  reader->records_ = get<std::uint64_t>(footer);
  const std::uint64_t frames = get<std::uint32_t>(footer + 8);
  if (frames * 8 > footer_at - kHeaderBytes) return reader->fail(footer_at, "seek table claims " + std::to_string(frames) + " frames, more than the file holds");
  reader->data_end_ = footer_at - frames * 8;
  reader->frame_offsets_.resize(frames);  // bounded by the file's real size, checked above
  if (frames > 0 && !pread_all(reader->fd_, reader->frame_offsets_.data(), frames * 8, reader->base_ + reader->data_end_)) {
    return reader->fail(reader->data_end_, "cannot read seek table");
  }
  std::uint64_t previous = kHeaderBytes;
  for (std::size_t i = 0; i < frames; ++i) {
    std::uint64_t at = reader->frame_offsets_[i];
    bool first_ok = i > 0 || at == kHeaderBytes;
    if (!first_ok || at < previous || at + kFrameHeaderBytes > reader->data_end_ || (i > 0 && at == previous)) {
      return reader->fail(reader->data_end_ + 8 * i, "seek table entry " + std::to_string(i) + " is out of order or out of range");
    }
    previous = at;
  }
  if (frames == 0 && reader->data_end_ != kHeaderBytes) return reader->fail(kHeaderBytes, "data without frames");
  if (frames == 0 && reader->records_ != 0) return reader->fail(footer_at, "records claimed without frames");
  ZSTD_DCtx* dctx = take_dctx();
  if (dctx == nullptr) return Status::error(Code::kResources, path, "cannot create a zstd context");
  reader->dctx_ = dctx;
  return reader;
}

RecordReader::~RecordReader() {
  if (fd_ >= 0) ::close(fd_);
  give_back_dctx(static_cast<ZSTD_DCtx*>(dctx_));
}

// Bytes [at, at + size) of the file, from a buffer refilled kReadAheadBytes at a time (or the
// whole range when larger): one pread per many small frames instead of two per frame — the
// partition's chunk files have frames of a few KB when there are many chunks.
const std::byte* RecordReader::fetch(std::uint64_t at, std::uint64_t size) {
  if (at >= buffer_at_ && at + size <= buffer_at_ + buffer_.size()) return buffer_.data() + (at - buffer_at_);
  const std::uint64_t want = std::max<std::uint64_t>(size, std::min<std::uint64_t>(kReadAheadBytes, data_end_ - at));
  buffer_.resize(static_cast<std::size_t>(want));
  buffer_at_ = at;
  if (!pread_all(fd_, buffer_.data(), buffer_.size(), base_ + at)) {
    buffer_.clear();
    return nullptr;
  }
  return buffer_.data();
}

Result<RecordReader::FrameHeader> RecordReader::frame_header() {
  const std::uint64_t at = frame_offsets_[next_frame_];
  const std::uint64_t end = next_frame_ + 1 < frame_offsets_.size() ? frame_offsets_[next_frame_ + 1] : data_end_;
  auto frame = [&] { return "frame " + std::to_string(next_frame_) + ": "; };  // built only on failure
  // The seek table bounds the frame before anything is read (open() checked end > at).
  if (end - at > kFrameHeaderBytes + ZSTD_compressBound(kMaxRecordFrameBytes)) return fail(at, frame() + "compressed size out of range");
  // At least the 8-byte frame header (open() checked at + 8 <= data_end): a damaged seek table
  // can put the next frame closer than that, and the header is read before it is checked.
  const std::byte* bytes = fetch(at, std::max<std::uint64_t>(end - at, kFrameHeaderBytes));
  if (bytes == nullptr) return fail(at, frame() + "cannot read frame");
  const std::uint64_t compressed = get<std::uint32_t>(bytes);
  const std::uint64_t plain = get<std::uint32_t>(bytes + 4);
  if (at + kFrameHeaderBytes + compressed != end) return fail(at, frame() + "compressed size does not match the seek table");
  if (plain == 0 || plain > kMaxRecordFrameBytes || plain % record_size_ != 0) {
    return fail(at + 4, frame() + "uncompressed size " + std::to_string(plain) + " is not a whole number of records within the limit");
  }
  return FrameHeader{at, bytes, compressed, plain};
}

// After the last frame, decoded or passed over: the frames must have held the records the
// seek table claims, or a caller counting them would trust a damaged file.
Status RecordReader::check_end() const {
  if (records_read_ == records_) return {};
  return fail(data_end_, "seek table claims " + std::to_string(records_) + " records, frames hold " + std::to_string(records_read_));
}

Result<std::span<const std::byte>> RecordReader::next() {
  if (next_frame_ >= frame_offsets_.size()) {
    GM_RETURN_IF_ERROR(check_end());
    return std::span<const std::byte>();
  }
  auto header = frame_header();
  if (!header) return header.status();
  const auto [at, bytes, compressed, plain] = *header;
  auto frame = [&] { return "frame " + std::to_string(next_frame_) + ": "; };  // built only on failure
  plain_.resize(plain);
  std::vector<std::byte>& target = columns_.empty() ? plain_ : column_buffer_;
  target.resize(plain);
  std::size_t got = ZSTD_decompressDCtx(static_cast<ZSTD_DCtx*>(dctx_), target.data(), target.size(), bytes + kFrameHeaderBytes, compressed);
  if (ZSTD_isError(got)) return fail(at + kFrameHeaderBytes, frame() + "corrupt (" + ZSTD_getErrorName(got) + ")");
  if (got != plain) return fail(at + kFrameHeaderBytes, frame() + "decompressed to " + std::to_string(got) + " bytes, expected " + std::to_string(plain));
  if (!columns_.empty()) from_columns(columns_, column_buffer_.data(), record_size_, plain_);
  ++next_frame_;
  records_read_ += plain / record_size_;
  return std::span<const std::byte>(plain_.data(), plain_.size());
}

Result<std::uint64_t> RecordReader::skip() {
  if (next_frame_ >= frame_offsets_.size()) {
    GM_RETURN_IF_ERROR(check_end());
    return std::uint64_t{0};
  }
  auto header = frame_header();
  if (!header) return header.status();
  ++next_frame_;
  records_read_ += header->plain / record_size_;
  return header->plain / record_size_;
}

}  // namespace gaussmesh::format
