// The partition run: the state one partition_mesh call carries through its steps, each in a file
// of its own — ingest.cpp (pass 0), chunk_plan.cpp (cells and owners), ring_expansion.cpp (the
// chunk sets), chunk_writer.cpp (the chunk files) — run in order by partition_run.cpp.
// Vertex-indexed data lives in spill files behind one bounded block cache; faces are only ever
// read sequentially, from the face spill.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <tbb/task_arena.h>

#include "format/mesh_reader.h"
#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/partition/block_cache.h"
#include "stream/partition/cell_grid.h"
#include "stream/partition/chunk_partition.h"
#include "stream/partition/chunk_sets.h"
#include "stream/partition/face_spill.h"
#include "stream/partition/file_window.h"

namespace gaussmesh::stream::detail {

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

static_assert(sizeof(Vec3f) == kPositionRecordBytes && sizeof(std::uint32_t) == kOwnerRecordBytes);

class PartitionRun {
 public:
  PartitionRun(const PartitionOptions& options, Partition& out) : options_(options), out_(out) {}
  Status run(const std::string& input_path, const format::ReadOptions& read);

 private:
  Status ingest(const std::string& input_path, const format::ReadOptions& read);
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
  std::size_t window_bytes() const;
  Status expand_rings();
  Status write_chunks();
  // Calls fn(begin, end) on pieces of [0, n), on the run's threads when there are several
  // (fn must be safe to run at once on disjoint pieces).
  template <class Fn>
  void for_pieces(std::size_t n, Fn&& fn);
  // Per-vertex counts over positions.bin: count(histogram, position) for every vertex, each
  // thread into its own array of `size` zeros, summed into the result.
  template <class Count>
  Result<std::vector<std::uint32_t>> count_positions(std::size_t size, Count&& count);

  const PartitionOptions& options_;
  const char* scan_pass_ = "rings";  // what scan_faces reports to options_.progress
  Partition& out_;
  std::shared_ptr<VertexFiles> vertex_files_;  // positions (pass 0) and owners (the owner pass)
  std::string faces_path_, owners_path_;
  Planner planner_;
  std::unique_ptr<BlockCache> cache_;
  std::unique_ptr<CachedArray<std::uint32_t>> owners_;  // owners.bin: the scans need only owners
  int owners_file_ = -1;                                 // its file in the cache (FaceWindows read it too)
  std::unique_ptr<ChunkSets> sets_;
  std::unique_ptr<CachedBitmap> has_extras_;
  std::unique_ptr<CachedBitmap> frontier_[2];
  std::uint64_t bytes_spilled_ = 0;
  std::unique_ptr<tbb::task_arena> arena_;  // the plan's scans with threads > 1
};

}  // namespace gaussmesh::stream::detail
