// The memory this process may use: physical memory, or less where the process runs under a
// limit — its cgroup's (a container's, a systemd unit's) or an rlimit. Past a cgroup limit the
// kernel kills the process instead of failing an allocation, so the automatic budgets are taken
// from this and an explicit --memory above it is refused (docs/cli.md, "Memory budget").
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace gaussmesh::stream {

// The memory cgroup limit of the process whose /proc/<pid>/cgroup reads `proc_cgroup`, with the
// cgroup file systems mounted under `mount_root` (/sys/fs/cgroup): the least of memory.max
// (cgroup v2, at the root or under unified/) and memory.limit_in_bytes (v1, under memory/) over
// its group and every group above it. 0 when there is none or it cannot be read.
std::uint64_t cgroup_memory_limit(std::string_view proc_cgroup, const std::string& mount_root);

// The least of physical memory, this process's cgroup limit and its RLIMIT_AS and RLIMIT_DATA;
// `limited` tells whether a cgroup limit or an rlimit is what set it. 0 when nothing is known.
struct MemoryLimit {
  std::uint64_t bytes = 0;
  bool limited = false;
  const char* by = "physical memory";  // or "cgroup memory limit", "RLIMIT_AS", "RLIMIT_DATA"
};
MemoryLimit process_memory_limit();

}  // namespace gaussmesh::stream
