// The chunk scheduler: chunks in parallel on a oneTBB arena, free pages released within the
// budget. See chunk_scheduler.h.
#include "stream/pipeline/chunk_scheduler.h"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <vector>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "stream/core/process_memory.h"

namespace gaussmesh::stream {

format::Status for_each_chunk(const Partition& partition, std::uint32_t threads, const ChunkBody& body,
                              const ChunkProgress& progress, const MemoryBudget& budget) {
  return for_each_chunk(
      partition.chunks.size(), [&](std::size_t c) { return partition.chunks[c]; }, threads, body, progress, budget);
}

format::Status for_each_chunk(std::size_t count, const std::function<ChunkInfo(std::size_t)>& info_of,
                              std::uint32_t threads, const ChunkBody& body, const ChunkProgress& progress,
                              const MemoryBudget& budget) {
  std::vector<format::Status> errors(count);
  std::atomic<bool> failed{false};
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex, release_mutex;
  std::uint64_t released_at = 0;  // resident bytes after the last release (under release_mutex)
  // Under small budgets the process's own working set is above 7/8 of the budget all along; a
  // smaller step between releases costs many times the page faults for no lower peak.
  constexpr std::uint64_t kMinGrowth = std::uint64_t{8} << 20;
  const std::uint64_t release_above = budget.fraction(7, 8);
  const std::uint64_t release_step = std::max<std::uint64_t>(budget.fraction(1, 8), kMinGrowth);
  tbb::enumerable_thread_specific<ChunkSamplerWorkspace> workspaces;
  tbb::task_arena arena(static_cast<int>(std::max<std::uint32_t>(threads, 1)));
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t c) {
      if (failed) return;
      // Isolated: while the body waits in a nested parallel loop (the adjacency, the sampler),
      // this thread must not start another chunk, which would take the same thread's workspace
      // (and hold a second chunk).
      format::Status st;
      tbb::this_task_arena::isolate([&] {
        auto chunk = load_chunk(info_of(c));
        st = chunk ? body(c, *chunk, workspaces.local()) : chunk.status();
      });
      if (!st) {
        errors[c] = st;
        failed = true;
        return;
      }
      const std::size_t n = ++done;
      if (budget.is_limited()) {
        std::unique_lock lock(release_mutex, std::try_to_lock);
        const std::uint64_t rss = lock ? current_rss() : 0;
        if (rss > released_at + release_step && rss > release_above) {
          release_free_memory();
          released_at = current_rss();
        }
      }
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        progress(n, count);
      }
    });
  });
  workspaces.clear();
  release_free_memory();
  for (const format::Status& e : errors)
    if (!e) return e;
  return format::Status();
}

}  // namespace gaussmesh::stream
