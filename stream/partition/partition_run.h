// The partition run: the state one partition_mesh call carries through its steps, each in a file
// of its own — ingest.cpp (the ingest pass), chunk_plan.cpp (cells and owners), ring_expansion.cpp (the
// chunk sets), chunk_writer.cpp (the chunk files) — run in order by partition_run.cpp.
// Vertex-indexed data lives in spill files behind one bounded block cache; faces are only ever
// read sequentially, from the face spill.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "format/mesh_reader.h"
#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/core/memory_budget.h"
#include "stream/partition/block_cache.h"
#include "stream/partition/cell_grid.h"
#include "stream/partition/chunk_partition.h"
#include "stream/partition/chunk_sets.h"
#include "stream/partition/face_spill.h"
#include "stream/partition/file_window.h"

namespace gaussmesh::stream::detail {

// The plan's and the renumbering's scans of the positions compute per vertex (a cell, a
// sub-cell code, an owner) and run on the run's threads: up to five scans of every vertex would
// otherwise be a long serial step. Pieces are small enough that the tests' shapes take the threaded path.
constexpr std::size_t kPlanPieceVertices = std::size_t{1} << 13;

using format::Result;
using format::Status;
using format::Triangle;
using format::Vec3f;

static_assert(sizeof(Vec3f) == 12 && sizeof(Triangle) == 12, "spill layouts assume packed values");

struct Planner {
  Grid grid;
  std::vector<std::uint32_t> cell_chunk;  // linear cell -> chunk, or kSplitCell | split
  std::vector<Partition::SplitCell> splits;
  std::uint32_t chunks = 0;
  std::vector<std::uint64_t> owned_vertices;
  std::uint32_t owner(const Vec3f& p) const { return owner_in(grid, cell_chunk, splits, p); }
};

// How the run divides its memory budget (PartitionOptions::memory_bytes), every share drawn here:
//   cache      half: the block cache over the vertex-indexed files, the scans' two file windows
//              (window each) taken out of it;
//   frames     an eighth: the final scan's staged chunk frames, which may also take what the
//              cache leaves of its half, up to frames_at_most (a quarter) in all;
//   sub_cells  an eighth: the plan's counts of the split cells' sub-cells;
//   per_chunk  the budget over the threads: the sample pass works on one chunk per thread, and this sets
//              the chunk size (kChunkBytesPerFace);
// the rest is the reader's window, the scan buffers, the cell tables and the zstd contexts.
struct PartitionShares {
  PartitionShares(const MemoryBudget& budget, std::uint32_t threads)
      : cache(budget.fraction(1, 2)),
        frames(budget.fraction(1, 8)),
        frames_at_most(budget.fraction(1, 4)),
        sub_cells(budget.fraction(1, 8)),
        per_chunk(budget.per_part(threads)),
        window(std::clamp<std::size_t>(budget.fraction(1, 64), std::size_t{16} << 10, std::size_t{1} << 20)) {}
  std::uint64_t cache, frames, frames_at_most, sub_cells, per_chunk;
  std::size_t window;  // one of the scans' two file windows (owners, a bitmap)
};

static_assert(sizeof(Vec3f) == kPositionRecordBytes && sizeof(std::uint32_t) == kOwnerRecordBytes);

class PartitionRun {
 public:
  PartitionRun(const PartitionOptions& options, Partition& out)
      : options_(options), shares_(MemoryBudget(options.memory_bytes), options.threads), out_(out) {}
  Status run(const std::string& input_path, const format::ReadOptions& read);

 private:
  Status ingest(const std::string& input_path, const format::ReadOptions& read);
  // The spatial renumbering (reorder.cpp, spatial_order.h) of an input the ingest found
  // scattered, or to weld it; only for inputs with fewer than 2^32 / 3 faces (corner slots are
  // 32-bit).
  Status reorder(bool weld);
  bool reorder_fits() const;
  // Calls fn(faces) for every frame of the face spill, in order, with every corner checked first
  // (a corner beyond the vertex count is kBadInput).
  template <class Fn>
  Status for_each_spilled_frame(Fn&& fn);
  Status plan();
  // Calls fn(face id, triangle, tag) for every face in order, tag = tag_of(triangle, windows)
  // (0 when tag_of is nullptr) computed first for each frame on the read-ahead thread (FaceWindows: owners.bin and, when
  // bitmap >= 0, that cache file, read through the windows; tag_of must not touch the cache).
  // After each frame, stops early when the cache or a window has failed or stop() says so.
  struct FaceWindows {
    FileWindow owners;
    std::optional<FileWindow> bitmap;
  };
  // `unknown` is the tag that tells fn to look the face up itself: the faces of frames whose
  // windows miss more than once per 256 faces get it (badly ordered input, where the cache may
  // still hold what the small windows cannot; see the tagger).
  // skip(frame), asked once per frame in order on the read-ahead thread (so it may read only
  // what no one writes during the scan), true: the frame is passed over undecompressed and fn
  // is not called for its faces (an earlier scan has checked them). begin(frame) is called on
  // this thread before the faces of each frame that is not skipped.
  template <class Tag, class Fn, class Stop>
  Status scan_faces(int bitmap, std::uint32_t unknown, Tag&& tag_of, Fn&& fn, Stop&& stop,
                    FrameReadAhead::Skip skip = [](std::size_t) { return false; },
                    const std::function<void(std::size_t)>& begin = [](std::size_t) {});
  Status expand_rings();
  Status write_chunks();
  // Calls fn(begin, end) on pieces of [0, n) of at least `grain` each, on the run's threads
  // when there are several (fn must be safe to run at once on disjoint pieces).
  template <class Fn>
  void for_pieces(std::size_t n, Fn&& fn, std::size_t grain = kPlanPieceVertices) {
    if (options_.threads <= 1 || n <= grain) {
      fn(std::size_t{0}, n);
      return;
    }
    if (!arena_) arena_ = std::make_unique<tbb::task_arena>(static_cast<int>(options_.threads));
    arena_->execute([&] {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& r) { fn(r.begin(), r.end()); });
    });
  }
  // Per-vertex counts over positions.bin: count(histogram, position) for every vertex, each
  // thread into its own array of `size` zeros, summed into the result.
  template <class Count>
  Result<std::vector<std::uint32_t>> count_positions(std::size_t size, Count&& count);

  const PartitionOptions& options_;
  const PartitionShares shares_;
  const char* scan_pass_ = "rings";  // what scan_faces reports to options_.progress
  Partition& out_;
  std::shared_ptr<VertexFiles> vertex_files_;  // positions (the ingest pass) and owners (the owner pass)
  std::string faces_path_, owners_path_;
  Planner planner_;
  std::unique_ptr<BlockCache> cache_;
  std::unique_ptr<CachedArray<std::uint32_t>> owners_;  // owners.bin: the scans need only owners
  int owners_file_ = -1;                                 // its file in the cache (FaceWindows read it too)
  std::unique_ptr<ChunkSets> sets_;
  std::unique_ptr<CachedBitmap> has_extras_;
  std::unique_ptr<CachedBitmap> frontier_[2];
  std::uint64_t bytes_spilled_ = 0;
  bool scattered_ = false;  // the ingest's OrderProbe found the input scattered
  std::unique_ptr<tbb::task_arena> arena_;  // the plan's scans with threads > 1
};

}  // namespace gaussmesh::stream::detail
