// The final scan: every face written to the record file of each chunk that holds it, the files
// compressed on the run's threads.
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "format/record_file.h"
#include "stream/partition/chunk_files.h"
#include "stream/partition/face_scan.h"
#include "stream/partition/partition_run.h"

namespace gaussmesh::stream::detail {
namespace {

// Records bound for a set of chunk writers, staged in one frame-sized buffer per chunk. A full
// buffer is one frame: compressed straight from the buffer (RecordWriter::append never copies a
// whole frame), inline or by `workers` compression threads fed through queues. Writer i belongs
// to worker i % workers, and the caller gives the writers of one worker one shared zstd context
// (write_chunks): a chunk's frames stay in order (one consumer per writer, FIFO) and no context
// is used by two threads. Memory: (chunks + spare) frames. Several workers keep compression off
// the scan's path: the scan's thread is the pass's bottleneck, and one compression thread could
// fall behind it.
class ChunkOutput {
 public:
  // Spare frames for the compression threads: enough that the scan seldom waits for one when
  // frames are small (many chunks per scan make every frame small).
  static std::size_t spare_frames(std::size_t chunks) { return std::max<std::size_t>(4, chunks / 8); }

  ChunkOutput(std::vector<std::unique_ptr<format::RecordWriter>>& writers, std::size_t frame_bytes, std::size_t workers)
      : writers_(writers), frame_bytes_(frame_bytes), jobs_(std::max<std::size_t>(workers, 1)) {
    const std::size_t spare = workers > 0 ? spare_frames(writers.size()) : 0;
    const std::size_t buffers = writers.size() + spare;
    wake_batch_ = std::clamp<std::size_t>(spare / (2 * std::max<std::size_t>(workers, 1)), 1, 16);
    arena_.reset(new std::byte[buffers * frame_bytes]);  // touched only as records arrive
    for (std::size_t i = 0; i < writers.size(); ++i) staged_.push_back({arena_.get() + i * frame_bytes, 0});
    for (std::size_t i = writers.size(); i < buffers; ++i) free_.push_back(arena_.get() + i * frame_bytes);
    wake_worker_ = std::make_unique<std::condition_variable[]>(jobs_.size());
    try {
      for (std::size_t w = 0; w < workers; ++w) workers_.emplace_back([this, w] { work(w); });
    } catch (const std::system_error&) {
      stop();  // no thread, or fewer than asked: compress inline (nothing was queued yet)
      stopping_ = false;
    }
  }
  ~ChunkOutput() { stop(); }

  // Room for one record of size bytes in chunk index i (0-based within the writers): the caller
  // writes the record there, then calls added(i, size). Writing fields straight into the frame
  // (not into a record that is then copied) keeps the scan clear of store-forwarding stalls: a
  // 16-byte load of a record just written by an 8- and a 12-byte store cost two thirds of the
  // scan's own time.
  std::byte* slot(std::size_t i) { return staged_[i].data + staged_[i].used; }
  void added(std::size_t i, std::size_t size) {
    Staged& s = staged_[i];
    s.used += size;
    if (s.used + size > frame_bytes_) submit(i);
  }
  bool failed() const { return failed_.load(std::memory_order_relaxed); }
  // Writes what is staged, waits for the compression threads, finishes every writer.
  Status finish() {
    stop();
    for (std::size_t i = 0; i < staged_.size() && status_.is_ok(); ++i) {
      if (staged_[i].used > 0) status_ = writers_[i]->append({staged_[i].data, staged_[i].used});
      staged_[i].used = 0;
    }
    for (auto& writer : writers_) {
      if (!status_.is_ok()) break;
      status_ = writer->finish();
    }
    return status_;
  }

 private:
  struct Staged {
    std::byte* data;
    std::size_t used;
  };
  struct Job {
    std::size_t writer;
    std::byte* data;
    std::size_t used;
  };

  void submit(std::size_t i) {
    Staged& s = staged_[i];
    if (workers_.empty()) {
      if (status_.is_ok()) status_ = writers_[i]->append({s.data, s.used});
      if (!status_.is_ok()) failed_ = true;
      s.used = 0;
      return;
    }
    const std::size_t w = i % workers_.size();
    std::unique_lock<std::mutex> lock(mutex_);
    jobs_[w].push_back({i, s.data, s.used});
    // A sleeping worker is woken once wake_batch_ frames wait for it (it then drains its queue),
    // not per frame: the scan hands over many small frames, and a futex wake and a context switch
    // per frame would leave the scan's thread idle much of the time. When no buffer is free,
    // every worker with work is woken before the scan waits.
    if (jobs_[w].size() >= wake_batch_) wake_worker_[w].notify_one();
    if (free_.empty()) {
      for (std::size_t v = 0; v < jobs_.size(); ++v)
        if (!jobs_[v].empty()) wake_worker_[v].notify_one();
    }
    buffer_free_.wait(lock, [&] { return !free_.empty(); });
    s.data = free_.back();
    s.used = 0;
    free_.pop_back();
  }
  void work(std::size_t w) {
    for (;;) {
      Job job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_worker_[w].wait(lock, [&] { return !jobs_[w].empty() || stopping_; });
        if (jobs_[w].empty()) return;
        job = jobs_[w].front();
        jobs_[w].pop_front();
      }
      Status status = failed() ? Status{} : writers_[job.writer]->append({job.data, job.used});
      std::lock_guard<std::mutex> lock(mutex_);
      if (!status.is_ok() && status_.is_ok()) {
        status_ = status;
        failed_ = true;
      }
      free_.push_back(job.data);
      buffer_free_.notify_one();
    }
  }
  void stop() {
    if (workers_.empty()) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    for (std::size_t w = 0; w < jobs_.size(); ++w) wake_worker_[w].notify_one();
    for (std::thread& worker : workers_) worker.join();
    workers_.clear();
  }

  std::vector<std::unique_ptr<format::RecordWriter>>& writers_;
  const std::size_t frame_bytes_;
  std::size_t wake_batch_ = 1;  // frames queued for a sleeping worker before it is woken: half its share of the spare frames, 1 to 16
  std::unique_ptr<std::byte[]> arena_;
  std::vector<Staged> staged_;
  std::vector<std::byte*> free_;
  std::vector<std::deque<Job>> jobs_;  // one queue per worker
  std::mutex mutex_;
  std::unique_ptr<std::condition_variable[]> wake_worker_;
  std::condition_variable buffer_free_;
  std::vector<std::thread> workers_;
  bool stopping_ = false;
  std::atomic<bool> failed_{false};
  Status status_;  // first error (written by a worker under mutex_, read after stop())
};

}  // namespace

Status PartitionRun::write_chunks() {
  const std::uint32_t chunks = planner_.chunks;
  out_.chunks.resize(chunks);
  for (std::uint32_t c = 0; c < chunks; ++c) {
    ChunkInfo& info = out_.chunks[c];
    info.id = c;
    info.owned_vertices = planner_.owned_vertices[c];
    info.path = chunk_file_path(out_.dir, c);
    info.vertex_files = vertex_files_;
  }
  if (chunks == 0) return {};
  // The staged frames take their share and what the block cache left of its own, up to
  // frames_at_most: the cache then grows no further than the rest, so the two stay within their
  // two shares. Spatially ordered input leaves the cache small, and larger frames make the final
  // scan faster and the chunk files smaller. Frames of at least 64 records; more chunks than fit
  // are written in several scans. With threads > 1, `threads` threads compress (ChunkOutput).
  const bool background = options_.threads > 1;
  const std::size_t workers = background ? options_.threads : 0;
  const std::uint64_t cache_left = shares_.cache - std::min<std::uint64_t>(cache_->bytes(), shares_.cache);
  const std::size_t writer_budget = static_cast<std::size_t>(std::min<std::uint64_t>(shares_.frames_at_most, shares_.frames + cache_left));
  cache_->limit(shares_.cache + shares_.frames - writer_budget);
  // Frames of at least 64 records when one scan holds every chunk. When it cannot, of at least
  // 256: later scans pass over the frames of faces they do not need (frame_chunks below), so
  // more, smaller groups cost little, while frames of 64 records would make a small budget
  // compress and write millions of tiny frames.
  std::size_t min_frame = 0, spare = 0, per_scan = 0;
  auto fit = [&](std::size_t records) {
    min_frame = records * kChunkFaceRecordBytes;
    spare = background ? ChunkOutput::spare_frames(0) : 0;
    per_scan = std::max<std::size_t>(writer_budget / min_frame, spare + 1) - spare;
    if (options_.max_open_chunks > 0) per_scan = std::min<std::size_t>(per_scan, options_.max_open_chunks);
    per_scan = std::min<std::size_t>(per_scan, chunks);
    if (background) {
      spare = ChunkOutput::spare_frames(per_scan);
      while (per_scan > 1 && (per_scan + spare) * min_frame > writer_budget) spare = ChunkOutput::spare_frames(--per_scan);
    }
  };
  fit(64);
  if (per_scan < chunks) fit(256);
  std::size_t frame_bytes = std::clamp(writer_budget / (per_scan + spare), min_frame, std::size_t{1} << 20);
  frame_bytes -= frame_bytes % kChunkFaceRecordBytes;
  // One zstd context per compression thread, shared by the writers that thread serves. A
  // renumbered input's chunk records compress several times less than an ordered input's (its
  // neighbours' ids differ by more), so they go at the renumbered spill's level: compressing
  // harder costs more time than the fewer bytes save (docs/partition.md).
  const int level = out_.reordered ? std::min(options_.compression_level, kRenumberedSpillLevel) : options_.compression_level;
  std::vector<std::unique_ptr<format::RecordCompressor>> compressors;
  for (std::size_t w = 0; w < std::max<std::size_t>(workers, 1); ++w) {
    auto compressor = format::RecordCompressor::create(level);
    if (!compressor) return compressor.status();
    compressors.push_back(std::move(*compressor));
  }
  format::RecordWriterOptions writer_options;
  writer_options.frame_bytes = frame_bytes;
  // Face id and vertex ids as differences from the previous record's, column by column.
  writer_options.columns = {{8, true}, {4, true}, {4, true}, {4, true}, {1, false}};
  // Writers keep their file open between frames when the descriptors fit well under the
  // process's limit; else each frame reopens its file (an open and a close per frame).
  rlimit files{};
  const std::uint64_t fd_limit = ::getrlimit(RLIMIT_NOFILE, &files) == 0 ? files.rlim_cur : 1024;
  writer_options.keep_open = per_scan <= 128 || per_scan + 256 <= fd_limit / 2;

  std::vector<std::unique_ptr<format::RecordWriter>> writers;
  std::vector<std::uint32_t> set;
  // With several scans (more chunks than the staged frames allow), the first records each face
  // frame's lowest and highest chunk, and a later scan skips the frames that send nothing to its
  // group: faces are in input order, chunks in Morton order, so on spatially ordered input a
  // group's faces lie in a few runs of frames. 8 bytes a face frame.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> frame_chunks;
  const bool several_scans = per_scan < chunks;
  if (options_.rings > 1) cache_->flush(has_extras_->file());  // the tags read it through a window
  for (std::uint32_t first = 0; first < chunks; first += static_cast<std::uint32_t>(per_scan)) {
    const std::uint32_t last = static_cast<std::uint32_t>(std::min<std::size_t>(first + per_scan, chunks));
    writers.clear();
    for (std::uint32_t c = first; c < last; ++c) {
      writer_options.shared = compressors[(c - first) % compressors.size()].get();
      auto writer = format::RecordWriter::create(out_.chunks[c].path, kChunkFaceRecordKind, kChunkFaceRecordBytes, writer_options);
      if (!writer) return writer.status();
      writers.push_back(std::move(*writer));
    }
    ChunkOutput output(writers, frame_bytes, workers);
    bool damaged = false;
    auto emit = [&](std::uint64_t f, const Triangle& t, std::uint32_t c, std::uint8_t flags) {
      std::byte* record = output.slot(c - first);
      std::memcpy(record, &f, 8);
      std::memcpy(record + 8, t.v, 12);
      record[20] = std::byte{flags};
      output.added(c - first, kChunkFaceRecordBytes);
      ChunkInfo& info = out_.chunks[c];
      ++info.faces;
      info.owned_faces += (flags & kOwnsFace) != 0;
    };
    // Tags: chunk + 1 for a face whose corners one chunk owns and no other chunk's rings hold
    // (most faces: all but the chunks' overlaps), which goes to that chunk alone and needs no
    // lookup here; 0 for the others and for untagged frames. The read-ahead thread reads the three owners and the three
    // has-extras bits through its windows.
    const bool rings = options_.rings > 1;
    auto tag_of = [&](const Triangle& t, FaceWindows& w) -> std::uint32_t {
      const std::uint32_t o = w.owners.u32(t.v[0]);
      if (w.owners.u32(t.v[1]) != o || w.owners.u32(t.v[2]) != o || o >= chunks) return 0;
      if (rings && (w.bitmap->bit(t.v[0]) || w.bitmap->bit(t.v[1]) || w.bitmap->bit(t.v[2]))) return 0;
      return o + 1;
    };
    const bool record_frames = several_scans && first == 0;
    std::size_t frame = 0;
    auto skip_frame = [&frame_chunks, record_frames, first, last](std::size_t k) {
      if (record_frames) return false;
      return k < frame_chunks.size() && (frame_chunks[k].second < first || frame_chunks[k].first >= last);
    };
    auto begin_frame = [&](std::size_t k) {
      frame = k;
      if (record_frames) frame_chunks.emplace_back(~std::uint32_t{0}, 0);
    };
    auto went_to = [&](std::uint32_t lowest, std::uint32_t highest) {
      if (!record_frames) return;
      auto& [lo, hi] = frame_chunks[frame];
      lo = std::min(lo, lowest);
      hi = std::max(hi, highest);
    };
    Status scanned = scan_faces(rings ? has_extras_->file() : -1, 0, tag_of, [&](std::uint64_t f, const Triangle& t, std::uint32_t tag) {
      if (tag != 0) {
        const std::uint32_t c = tag - 1;
        went_to(c, c);
        if (c >= first && c < last) emit(f, t, c, static_cast<std::uint8_t>(7 | kOwnsFace));
        return;
      }
      std::uint32_t owner[3];
      bool extras[3] = {false, false, false};
      for (int j = 0; j < 3; ++j) owner[j] = owners_->get(t.v[j]);
      if (rings)
        for (int j = 0; j < 3; ++j) extras[j] = has_extras_->test(t.v[j]);
      int lowest = 0;
      for (int j = 1; j < 3; ++j)
        if (t.v[j] < t.v[lowest]) lowest = j;
      const std::uint32_t face_owner = owner[lowest];
      if (owner[0] >= chunks || owner[1] >= chunks || owner[2] >= chunks) damaged = true;
      auto emit_to = [&](std::uint32_t c) {
        std::uint8_t flags = 0;
        for (int j = 0; j < 3; ++j) flags |= static_cast<std::uint8_t>(owner[j] == c) << j;
        if (face_owner == c) flags |= kOwnsFace;
        emit(f, t, c, flags);
      };
      // Most faces: one owner, no vertex in another chunk's rings.
      if (!extras[0] && !extras[1] && !extras[2] && owner[0] == owner[1] && owner[1] == owner[2]) {
        went_to(owner[0], owner[0]);
        if (owner[0] >= first && owner[0] < last) emit_to(owner[0]);
        return;
      }
      set.assign(owner, owner + 3);
      for (int j = 0; j < 3; ++j)
        if (extras[j]) sets_->for_each(t.v[j], [&](std::uint32_t e) { set.push_back(entry_chunk(e)); });
      std::sort(set.begin(), set.end());
      set.erase(std::unique(set.begin(), set.end()), set.end());
      if (set.back() >= chunks) damaged = true;
      went_to(set.front(), set.back());
      for (std::uint32_t c : set)
        if (c >= first && c < last) emit_to(c);
    }, [&] { return output.failed(); }, skip_frame, begin_frame);
    if (output.failed()) return output.finish();  // the writer's own error
    GM_RETURN_IF_ERROR(scanned);
    if (damaged) return Status::error(Code::kBadInput, out_.dir, "a temporary file names a chunk that does not exist (damaged)");
    GM_RETURN_IF_ERROR(output.finish());
    for (auto& writer : writers) bytes_spilled_ += writer->bytes_written();
  }
  // Every face and every vertex has exactly one owner.
  std::uint64_t owned_faces = 0, owned_vertices = 0;
  for (const ChunkInfo& info : out_.chunks) {
    owned_faces += info.owned_faces;
    owned_vertices += info.owned_vertices;
  }
  if (owned_faces != out_.faces || owned_vertices != out_.vertices) {
    return Status::error(Code::kProcessing, out_.dir,
                         "ownership does not add up: " + std::to_string(owned_faces) + " of " + std::to_string(out_.faces) +
                             " faces, " + std::to_string(owned_vertices) + " of " + std::to_string(out_.vertices) + " vertices");
  }
  return {};
}

}  // namespace gaussmesh::stream::detail
