// The process's memory as the system sees it: peak and current resident set, and handing the
// allocator's free pages back. The out-of-core passes check their budget against these.
#pragma once

#include <cstdint>

namespace gaussmesh::stream {

// The process's peak RSS so far, in bytes: since its last exec (/proc/self/status VmHWM), or
// getrusage's where /proc is missing (which carries a parent's peak over exec).
std::uint64_t peak_rss();
// The process's resident set now (0 where unknown).
std::uint64_t current_rss();

// Hands the allocator's free pages back to the system (glibc's malloc_trim; elsewhere nothing).
// Called between passes and between the stitch's steps, unconditionally: what one step freed is
// then not held, resident, under the next one's allocations. The cost is the next pass faulting
// the pages in again, which stays within the wall time's noise (docs/benchmarks.md).
void release_free_memory();

}  // namespace gaussmesh::stream
