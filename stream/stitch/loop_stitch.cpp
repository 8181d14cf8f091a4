// The loop stitch: runs joined into loops, loops and positions to files. See loop_stitch.h.
#include "stream/stitch/loop_stitch.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <span>

#include "format/file_io.h"
#include "format/record_file.h"
#include "stream/core/process_memory.h"
#include "stream/partition/id_indexed_file.h"
#include "stream/stitch/chunk_pieces.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;

format::Status damaged(const std::string& what) { return format::Status::error(format::Code::kBadInput, "stitch", what); }

// Positions by dense vertex id from the file stitch_loops writes: 12 bytes per vertex, read with
// pread on demand (the mesher caches what it reads).
class FilePositions final : public VertexPositionSource {
 public:
  FilePositions(int fd, std::string path, std::size_t count) : fd_(fd), path_(std::move(path)), count_(count) {}
  ~FilePositions() override { ::close(fd_); }
  format::Vec3f position(std::uint32_t v) override {
    float xyz[3] = {0, 0, 0};
    if (v >= count_ || ::pread(fd_, xyz, sizeof xyz, static_cast<off_t>(std::uint64_t{v} * sizeof xyz)) != sizeof xyz) {
      if (status_.is_ok())
        status_ = format::Status::error(format::Code::kOutput, path_, "cannot read the position of loop vertex " + std::to_string(v));
      return {};
    }
    return {xyz[0], xyz[1], xyz[2]};
  }
  // Ascending ids: one read per run of nearby ids (read_by_ascending_id); an id it cannot serve
  // (out of range, out of order, a failed read) is read alone, which records the error.
  void positions(std::span<const std::uint32_t> ids, std::span<format::Vec3f> out) override {
    ids = ids.first(std::min(ids.size(), out.size()));
    while (!ids.empty()) {
      const std::size_t served = read_by_ascending_id(fd_, count_, sizeof(format::Vec3f), ids, window_,
                                                      [&](std::size_t i, const std::byte* record) {
                                                        std::memcpy(&out[i], record, sizeof(format::Vec3f));
                                                      });
      if (served < ids.size()) out[served] = position(ids[served]);
      const std::size_t next = std::min(served + 1, ids.size());
      ids = ids.subspan(next);
      out = out.subspan(next);
    }
  }
  format::Status status() const override { return status_; }

 private:
  int fd_;
  std::string path_;
  std::size_t count_;
  format::Status status_;
  std::vector<std::byte> window_;
};

// The loop stitch's loop file: one dense vertex id (4 bytes) per entry, written at its place by
// write and read back a loop at a time by the mesher. The mesher walks the loops in file order,
// round after round, and most loops are a few entries: reads are served from a window of
// kWindowEntries (64 KiB) read ahead, one pread per window instead of one per loop (a million
// system calls on a detailed input of 10M triangles).
class FileLoopVertices final : public LoopVertexSource {
 public:
  static constexpr std::uint64_t kWindowEntries = 16384;

  FileLoopVertices(int fd, std::string path, std::uint64_t entries) : fd_(fd), path_(std::move(path)), entries_(entries) {}
  ~FileLoopVertices() override { ::close(fd_); }
  format::Status write(std::uint64_t first, std::span<const std::uint32_t> ids) {
    if (first + ids.size() > entries_) return damaged("a loop run lies outside its loop");
    window_.clear();
    if (!format::write_all(fd_, ids.data(), ids.size_bytes(), first * sizeof(std::uint32_t)))
      return format::Status::error(format::Code::kOutput, path_, "cannot write loop vertices: " + std::string(std::strerror(errno)));
    return format::Status();
  }
  bool read(std::uint64_t first, std::span<std::uint32_t> out) override {
    if (first + out.size() <= entries_) {
      if (first < window_first_ || first + out.size() > window_first_ + window_.size()) {
        window_.resize(std::min(std::max<std::uint64_t>(out.size(), kWindowEntries), entries_ - first));
        window_first_ = first;
        if (!format::pread_all(fd_, window_.data(), window_.size() * sizeof(std::uint32_t), first * sizeof(std::uint32_t)))
          window_.clear();
      }
      if (first >= window_first_ && first + out.size() <= window_first_ + window_.size()) {
        std::copy_n(window_.begin() + static_cast<std::ptrdiff_t>(first - window_first_), out.size(), out.begin());
        return true;
      }
    }
    if (status_.is_ok())
      status_ = format::Status::error(format::Code::kOutput, path_, "cannot read loop vertices " + std::to_string(first) + " on");
    return false;
  }
  format::Status status() const override { return status_; }

 private:
  int fd_;
  std::string path_;
  std::uint64_t entries_;
  format::Status status_;
  std::vector<std::uint32_t> window_;  // entries window_first_ .. window_first_ + size - 1
  std::uint64_t window_first_ = 0;
};

// Calls body(run index in chunk, index in run, entry) for every run vertex of a chunk's file,
// checking the file against the summary (its runs tile the records in order).
template <class Body>
format::Status read_run_vertices(const ChunkLoopSummary& chunk, Body&& body) {
  std::uint64_t expect = 0;
  for (const LoopRunRecord& r : chunk.runs) {
    if (r.offset != expect || r.length == 0) return damaged("the runs of " + chunk.path + " do not tile its records");
    expect += r.length;
  }
  if (expect != chunk.entries) return damaged("the runs of " + chunk.path + " do not tile its records");
  if (chunk.entries == 0) return format::Status();
  auto reader = format::RecordReader::open(chunk.path, kLoopVertexRecordKind, sizeof(LoopVertexEntry), chunk.segment);
  if (!reader) return reader.status();
  if ((*reader)->records() != chunk.entries) return damaged(chunk.path + " holds a different number of run vertices");
  std::uint64_t at = 0;
  std::size_t run = 0;
  for (;;) {
    auto frame = (*reader)->next();
    if (!frame) return frame.status();
    if (frame->empty()) break;
    for (std::size_t k = 0; k + sizeof(LoopVertexEntry) <= frame->size(); k += sizeof(LoopVertexEntry), ++at) {
      if (at >= chunk.entries) return damaged(chunk.path + " holds more run vertices than its runs");
      while (at >= chunk.runs[run].offset + chunk.runs[run].length) ++run;
      LoopVertexEntry e;
      std::memcpy(&e, frame->data() + k, sizeof e);
      body(run, static_cast<std::uint32_t>(at - chunk.runs[run].offset), e);
    }
  }
  if (at != chunk.entries) return damaged(chunk.path + " holds fewer run vertices than its runs");
  return format::Status();
}

}  // namespace

format::Result<PolygonGraphInput> stitch_loops(const std::vector<ChunkLoopSummary>& chunks, std::size_t patches,
                                               const std::vector<format::Vec3f>& plane_normal, const std::string& dir,
                                               const std::vector<std::pair<std::uint32_t, format::Vec3f>>& extra_vertices,
                                               LoopStitchStats* stats) {
  PolygonGraphInput g;
  g.patches = patches;
  g.patch_area.assign(patches, {0, 0, 0});
  g.patch_has_faces.assign(patches, 0);
  g.plane_normal = plane_normal;
  // Runs by first half-edge id.
  struct RunRef {
    std::uint64_t first;
    std::uint32_t chunk, index;
  };
  std::vector<RunRef> by_first;
  std::size_t total_runs = 0, total_records = extra_vertices.size();
  for (const ChunkLoopSummary& c : chunks) {
    total_runs += c.runs.size();
    total_records += c.vertices.size();
  }
  by_first.reserve(total_runs);
  for (std::uint32_t c = 0; c < chunks.size(); ++c) {
    for (std::uint32_t k = 0; k < chunks[c].runs.size(); ++k) {
      const LoopRunRecord& r = chunks[c].runs[k];
      if (r.patch >= patches) return damaged("a loop run names an unknown patch");
      if (r.min_index >= r.length) return damaged("a loop run's lowest half-edge lies outside it");
      by_first.push_back({r.first, c, k});
    }
    for (const auto& [p, sum] : chunks[c].areas) {
      if (p >= patches) return damaged("a vector area names an unknown patch");
      for (int k = 0; k < 3; ++k) g.patch_area[p][k] += sum[k];
      g.patch_has_faces[p] = 1;
    }
  }
  std::sort(by_first.begin(), by_first.end(), [](const RunRef& a, const RunRef& b) { return a.first < b.first; });
  for (std::size_t k = 1; k < by_first.size(); ++k)
    if (by_first[k].first == by_first[k - 1].first) return damaged("half-edge " + std::to_string(by_first[k].first) + " starts two runs");
  auto run_of = [&](std::size_t k) -> const LoopRunRecord& { return chunks[by_first[k].chunk].runs[by_first[k].index]; };
  // Each run's successor; every run must have exactly one predecessor.
  const std::size_t nr = by_first.size();
  std::vector<std::uint32_t> succ(nr);
  {
    std::vector<std::uint8_t> preds(nr, 0);
    for (std::size_t k = 0; k < nr; ++k) {
      const LoopRunRecord& r = run_of(k);
      auto it = std::lower_bound(by_first.begin(), by_first.end(), r.next,
                                 [](const RunRef& a, std::uint64_t x) { return a.first < x; });
      if (it == by_first.end() || it->first != r.next)
        return damaged("the half-edges of patch " + std::to_string(r.patch) + " do not close into a loop");
      const std::size_t s = it - by_first.begin();
      if (run_of(s).patch != r.patch || preds[s]++)
        return damaged("the half-edges of patch " + std::to_string(r.patch) + " do not close into a loop");
      succ[k] = static_cast<std::uint32_t>(s);
    }
  }
  // Loops: cycles of runs, each starting at its lowest half-edge id; a patch's loops in that order.
  struct LoopInfo {
    std::uint32_t patch;
    std::uint64_t min_id;
    std::uint32_t start;  // the run holding min_id (index in by_first)
    std::uint64_t length;
  };
  std::vector<LoopInfo> infos;
  std::size_t breaks = 0, halves = 0;
  {
    std::vector<std::uint8_t> walked(nr, 0);
    for (std::size_t k = 0; k < nr; ++k) {
      if (walked[k]) continue;
      LoopInfo info{run_of(k).patch, run_of(k).min_id, static_cast<std::uint32_t>(k), 0};
      for (std::size_t at = k; !walked[at]; at = succ[at]) {
        walked[at] = 1;
        const LoopRunRecord& r = run_of(at);
        info.length += r.length;
        breaks += r.breaks;
        if (r.min_id < info.min_id) {
          info.min_id = r.min_id;
          info.start = static_cast<std::uint32_t>(at);
        }
      }
      if (info.length >= 0xFFFFFFFFu) return damaged("a loop is too long");
      halves += info.length;
      infos.push_back(info);
    }
  }
  std::sort(infos.begin(), infos.end(),
            [](const LoopInfo& a, const LoopInfo& b) { return a.patch != b.patch ? a.patch < b.patch : a.min_id < b.min_id; });
  // Where each run's vertices go: its loop, and its offset there before the loop is turned to
  // start at min_id.
  std::vector<std::uint32_t> run_loop(nr), run_at(nr);
  std::vector<std::vector<std::uint32_t>> chunk_run(chunks.size());  // index in by_first of each chunk's runs
  for (std::uint32_t c = 0; c < chunks.size(); ++c) chunk_run[c].resize(chunks[c].runs.size());
  for (std::size_t k = 0; k < nr; ++k) chunk_run[by_first[k].chunk][by_first[k].index] = static_cast<std::uint32_t>(k);
  // Dense ids: every loop vertex, record and extra vertex, in global id order. Gathered from
  // the run files before the loops exist, summed up now and then (each vertex is on two loops).
  std::vector<std::uint32_t>& global = g.global;
  {
    constexpr std::size_t kSlack = std::size_t{1} << 18;  // 1 MiB of ids
    std::size_t unique = 0;
    auto compact = [&] {
      std::sort(global.begin(), global.end());
      global.erase(std::unique(global.begin(), global.end()), global.end());
      unique = global.size();
    };
    auto add = [&](std::uint32_t v) {
      make_room_for_one(global, unique, kSlack, compact);
      global.push_back(v);
    };
    for (const ChunkLoopSummary& c : chunks) {
      GM_RETURN_IF_ERROR(read_run_vertices(c, [&](std::size_t, std::uint32_t, const LoopVertexEntry& e) { add(e.vertex); }));
      for (const LoopVertexRecord& r : c.vertices) add(r.vertex);
    }
    for (const auto& e : extra_vertices) add(e.first);
    compact();
    global.shrink_to_fit();
  }
  release_free_memory();  // the gathering's spare capacity
  const std::size_t nv = global.size();
  const DenseIds dense(global);
  // Positions in dense order, to a file, one range of dense ids at a time (the run files read
  // once per range), before the loops exist: the range buffer and the loops are never held
  // together.
  const std::string path = dir + "/loop-positions.bin";
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return format::Status::error(format::Code::kOutput, path, std::strerror(errno));
  auto source = std::make_shared<FilePositions>(fd, path, nv);
  {
    constexpr std::size_t kRange = (std::size_t{8} << 20) / sizeof(format::Vec3f);
    std::vector<format::Vec3f> buffer;
    std::vector<std::uint8_t> filled;
    std::size_t lo = 0;
    auto put = [&](std::uint32_t v, const format::Vec3f& p) {
      const std::size_t d = dense(v);
      if (d < lo || d >= lo + buffer.size()) return;
      buffer[d - lo] = p;
      filled[d - lo] = 1;
    };
    for (lo = 0; lo < nv; lo += kRange) {
      const std::size_t n = std::min(nv - lo, kRange);
      buffer.assign(n, {});
      filled.assign(n, 0);
      for (const ChunkLoopSummary& c : chunks) {
        GM_RETURN_IF_ERROR(read_run_vertices(c, [&](std::size_t, std::uint32_t, const LoopVertexEntry& e) { put(e.vertex, e.position); }));
        for (const LoopVertexRecord& r : c.vertices) put(r.vertex, r.position);
      }
      for (const auto& [v, p] : extra_vertices) put(v, p);
      if (std::find(filled.begin(), filled.end(), 0) != filled.end()) return damaged("a loop vertex has no position");
      const std::size_t bytes = buffer.size() * sizeof(format::Vec3f);
      if (!format::write_all(fd, buffer.data(), bytes, lo * sizeof(format::Vec3f)))
        return format::Status::error(format::Code::kOutput, path, "cannot write loop vertex positions: " + std::string(std::strerror(errno)));
    }
  }
  release_free_memory();  // the range buffer
  // The loops, in dense ids, to a file: loop l is entries loop_offset[l] .. of it, starting at
  // its lowest half-edge. Each run's vertices go to their place in one write (two when the
  // loop's start lies inside it), so only one run is held at a time.
  const std::size_t nl = infos.size();
  g.loop_patch.resize(nl);
  g.loop_offset.assign(nl + 1, 0);
  std::vector<std::uint32_t> rotation(nl);
  for (std::uint32_t l = 0; l < nl; ++l) {
    g.loop_patch[l] = infos[l].patch;
    g.loop_offset[l + 1] = g.loop_offset[l] + infos[l].length;
    rotation[l] = run_of(infos[l].start).min_index;
    std::uint32_t at = 0, k = infos[l].start;
    do {
      run_loop[k] = l;
      run_at[k] = at;
      at += run_of(k).length;
      k = succ[k];
    } while (k != infos[l].start);
  }
  succ = {};
  const std::string loop_path = dir + "/loop-vertices.bin";
  const int loop_fd = ::open(loop_path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (loop_fd < 0) return format::Status::error(format::Code::kOutput, loop_path, std::strerror(errno));
  auto loop_source = std::make_shared<FileLoopVertices>(loop_fd, loop_path, g.loop_offset.back());
  {
    std::vector<std::uint32_t> run_ids;
    std::size_t run_index = kNone;  // in by_first
    // Writes run_ids at entry `at` of loop l onwards (wrapping round to its start).
    auto put = [&](std::uint32_t l, std::uint64_t at, std::span<const std::uint32_t> ids) -> format::Status {
      const std::uint64_t length = infos[l].length;
      while (!ids.empty()) {
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(ids.size(), length - at));
        GM_RETURN_IF_ERROR(loop_source->write(g.loop_offset[l] + at, ids.first(n)));
        ids = ids.subspan(n);
        at = 0;
      }
      return format::Status();
    };
    auto flush = [&]() -> format::Status {
      if (run_index == kNone || run_ids.empty()) return format::Status();
      const std::uint32_t l = run_loop[run_index];
      const std::uint64_t length = infos[l].length;
      const std::uint64_t at = (run_at[run_index] + length - rotation[l]) % length;
      GM_RETURN_IF_ERROR(put(l, at, run_ids));
      run_ids.clear();
      return format::Status();
    };
    for (std::uint32_t c = 0; c < chunks.size(); ++c) {
      format::Status written;
      GM_RETURN_IF_ERROR(read_run_vertices(chunks[c], [&](std::size_t run, std::uint32_t, const LoopVertexEntry& e) {
        const std::uint32_t k = chunk_run[c][run];
        if (k != run_index) {
          if (written.is_ok()) written = flush();
          run_index = k;
        }
        run_ids.push_back(dense(e.vertex));
      }));
      GM_RETURN_IF_ERROR(written);
      GM_RETURN_IF_ERROR(flush());
      run_index = kNone;
    }
  }
  g.loop_source = std::move(loop_source);
  g.role.assign(nv, VertexRole::kNone);
  g.interior_samples.assign(patches, {});
  std::vector<std::uint8_t> has_record(nv, 0);
  for (const ChunkLoopSummary& c : chunks) {
    for (const LoopVertexRecord& r : c.vertices) {
      const std::uint32_t d = dense(r.vertex);
      if (has_record[d]++) return damaged("vertex " + std::to_string(r.vertex) + " twice");
      g.role[d] = r.role;
      if (r.degree > 0 && r.role != VertexRole::kNone) ++g.graph.corners;
      if (r.interior_patch == kNone) continue;
      if (r.interior_patch >= patches) return damaged("an interior sample names an unknown patch");
      g.interior_samples[r.interior_patch].push_back(d);
    }
  }
  has_record = {};
  for (auto& list : g.interior_samples) std::sort(list.begin(), list.end());
  g.graph.feature_edges = breaks + (halves - breaks) / 2;
  g.position_source = std::move(source);
  g.vertex_count = nv;
  if (stats) *stats = {nr, halves, nv};
  return g;
}

}  // namespace gaussmesh::stream
