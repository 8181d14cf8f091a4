// The chunk scheduler of the out-of-core passes: loads chunks from disk, `threads` at a time, and
// runs a pass's body on each, within the pass's memory budget.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>

#include "format/status.h"
#include "stream/core/memory_budget.h"
#include "stream/partition/chunk_partition.h"
#include "stream/sampling/chunk_sampler.h"

namespace gaussmesh::stream {

// A pass's work on one chunk: (chunk index, chunk, this thread's workspace).
using ChunkBody = std::function<format::Status(std::size_t, const ChunkMesh&, ChunkSamplerWorkspace&)>;
// (chunks done, chunks), called after each chunk from one thread at a time.
using ChunkProgress = std::function<void(std::size_t, std::size_t)>;

// Loads every chunk of `partition`, `threads` at a time (a oneTBB task arena), and calls body on
// it, then progress. The first error stops the chunks not yet started and is returned.
// budget (unlimited: no check) is the pass's. Each chunk allocates and frees arrays of its own
// size, so the allocator's arenas fill with free pages that stay resident. When the resident set
// passes 7/8 of the budget and has grown by 1/8 of it (at least 8 MiB) since the last release,
// free pages go back to the system (release_free_memory); not after every chunk, because
// re-touching released pages is costly (docs/benchmarks.md). Free pages also go back once the
// chunks are done.
format::Status for_each_chunk(const Partition& partition, std::uint32_t threads, const ChunkBody& body,
                              const ChunkProgress& progress, const MemoryBudget& budget = {});
// The same over `count` chunk files that info_of(i) describes (simplify's loop chunks, the fetch
// pass's chunks): each built when it is loaded, so that no second list of chunk paths is held.
format::Status for_each_chunk(std::size_t count, const std::function<ChunkInfo(std::size_t)>& info_of,
                              std::uint32_t threads, const ChunkBody& body, const ChunkProgress& progress,
                              const MemoryBudget& budget = {});

}  // namespace gaussmesh::stream
