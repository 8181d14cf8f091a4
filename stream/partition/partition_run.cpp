// The partition run from start to end: the steps in order, the block cache and the chunk sets
// they share, the timings, and the temporary files removed once the chunk files are written.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <memory>
#include <string>

#include "stream/core/stopwatch.h"
#include "stream/partition/chunk_files.h"
#include "stream/partition/partition_run.h"
#include "stream/partition/spatial_order.h"

namespace gaussmesh::stream::detail {

Status PartitionRun::run(const std::string& input_path, const format::ReadOptions& read) {
  auto start = std::chrono::steady_clock::now();
  GM_RETURN_IF_ERROR(ingest(input_path, read));
  out_.seconds_ingest = seconds_since(start);
  const bool weld = options_.reorder_scattered && should_weld(options_.weld, out_.vertices, out_.faces);
  // Beyond reorder_fits, the input goes on as it is (scattered input is then slow).
  if (options_.reorder_scattered && (scattered_ || weld) && reorder_fits()) {
    start = std::chrono::steady_clock::now();
    GM_RETURN_IF_ERROR(reorder(weld));
    out_.seconds_reorder = seconds_since(start);
  }
  start = std::chrono::steady_clock::now();
  GM_RETURN_IF_ERROR(plan());
  out_.steps.plan = seconds_since(start);
  auto step = std::chrono::steady_clock::now();
  // The cache's share, less the scans' two windows (PartitionShares).
  cache_ = std::make_unique<BlockCache>(shares_.cache - 2 * shares_.window);
  auto owners = cache_->open_file(owners_path_);
  if (!owners) return owners.status();
  owners_ = std::make_unique<CachedArray<std::uint32_t>>(*cache_, *owners);
  owners_file_ = *owners;
  ChunkFileMaker maker(out_.dir, planner_.chunks, options_.threads > 1);
  if (options_.rings > 1) {
    auto index = cache_->add_file(out_.dir + "/set-index.bin");
    auto slots = cache_->add_file(out_.dir + "/sets.bin");
    auto nodes = cache_->add_file(out_.dir + "/set-nodes.bin");
    auto extras = cache_->add_file(out_.dir + "/has-extras.bin");
    auto f0 = cache_->add_file(out_.dir + "/frontier-0.bin");
    auto f1 = cache_->add_file(out_.dir + "/frontier-1.bin");
    for (const auto* r : {&index, &slots, &nodes, &extras, &f0, &f1})
      if (!*r) return r->status();
    sets_ = std::make_unique<ChunkSets>(*cache_, *index, *slots, *nodes);
    has_extras_ = std::make_unique<CachedBitmap>(*cache_, *extras);
    frontier_[0] = std::make_unique<CachedBitmap>(*cache_, *f0);
    frontier_[1] = std::make_unique<CachedBitmap>(*cache_, *f1);
    GM_RETURN_IF_ERROR(expand_rings());
  }
  out_.steps.rings = seconds_since(step);
  step = std::chrono::steady_clock::now();
  scan_pass_ = "chunks";
  maker.finish();
  GM_RETURN_IF_ERROR(write_chunks());
  GM_RETURN_IF_ERROR(cache_->status());
  out_.bytes_spilled = bytes_spilled_ + cache_->bytes_written();
  out_.cache_misses = cache_->misses();
  out_.cache_bytes = cache_->bytes();
  cache_.reset();
  // The face spill is no longer needed; the chunk files and the vertex files (load_chunk reads
  // positions and owners from them) stay until the Partition goes.
  ::unlink(faces_path_.c_str());
  for (const char* name : {"/set-index.bin", "/sets.bin", "/set-nodes.bin", "/has-extras.bin", "/frontier-0.bin", "/frontier-1.bin"}) {
    ::unlink((out_.dir + name).c_str());
  }
  out_.steps.chunks = seconds_since(step);
  out_.seconds_partition = seconds_since(start);
  return {};
}

}  // namespace gaussmesh::stream::detail
