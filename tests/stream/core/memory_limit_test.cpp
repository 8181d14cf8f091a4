// The cgroup memory limit as read from /proc/self/cgroup and the cgroup file systems: v1's
// memory.limit_in_bytes and v2's memory.max, the least over the group and its parents, "max" and
// v1's near-2^63 "no limit" read as none, and lines that name no memory group ignored.
#include "stream/core/memory_limit.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

using testing::ScratchDir;

void write_limit(const std::string& dir, const char* file, const std::string& value) {
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/" + file) << value << "\n";
}

TEST(MemoryLimit, CgroupV1TakesTheLeastOverTheGroupAndItsParents) {
  ScratchDir root;
  const std::string memory = root.path().string() + "/memory";
  write_limit(memory, "memory.limit_in_bytes", "9223372036854771712");  // the root: no limit
  write_limit(memory + "/jobs", "memory.limit_in_bytes", "536870912");
  write_limit(memory + "/jobs/run7", "memory.limit_in_bytes", "1073741824");
  const std::string self = "9:name=systemd:/\n4:memory:/jobs/run7\n1:cpu:/\n";
  EXPECT_EQ(cgroup_memory_limit(self, root.path().string()), 536870912u);  // the parent's is less
  write_limit(memory + "/jobs/run7", "memory.limit_in_bytes", "268435456");
  EXPECT_EQ(cgroup_memory_limit(self, root.path().string()), 268435456u);
  // The controller shares a hierarchy with others.
  EXPECT_EQ(cgroup_memory_limit("4:cpu,memory:/jobs/run7\n", root.path().string()), 268435456u);
  // No memory line, or a group with no limit anywhere: none.
  EXPECT_EQ(cgroup_memory_limit("1:cpu:/jobs/run7\n", root.path().string()), 0u);
  EXPECT_EQ(cgroup_memory_limit("4:memory:/\n", root.path().string()), 0u);
}

TEST(MemoryLimit, CgroupV2ReadsMemoryMaxAtTheRootOrUnderUnified) {
  ScratchDir root;
  write_limit(root.path().string() + "/user.slice/app.scope", "memory.max", "max");
  write_limit(root.path().string() + "/user.slice", "memory.max", "805306368");
  EXPECT_EQ(cgroup_memory_limit("0::/user.slice/app.scope\n", root.path().string()), 805306368u);
  write_limit(root.path().string() + "/user.slice", "memory.max", "max");
  EXPECT_EQ(cgroup_memory_limit("0::/user.slice/app.scope\n", root.path().string()), 0u);
  // A hybrid set-up mounts v2 under unified/.
  write_limit(root.path().string() + "/unified/box", "memory.max", "134217728");
  EXPECT_EQ(cgroup_memory_limit("0::/box\n", root.path().string()), 134217728u);
}

TEST(MemoryLimit, MalformedLinesAndValuesAreNoLimit) {
  ScratchDir root;
  write_limit(root.path().string() + "/memory/a", "memory.limit_in_bytes", "12x");
  write_limit(root.path().string() + "/b", "memory.max", "");
  for (const char* text : {"", "garbage\n", "4:memory:/a\n", "0::/b\n", "4:memory:relative\n", "4:memory:/../etc\n"})
    EXPECT_EQ(cgroup_memory_limit(text, root.path().string()), 0u) << text;
}

TEST(MemoryLimit, TheProcessLimitIsAtMostPhysicalMemory) {
  const MemoryLimit limit = process_memory_limit();
  const std::uint64_t physical = std::uint64_t(::sysconf(_SC_PHYS_PAGES)) * std::uint64_t(::sysconf(_SC_PAGESIZE));
  EXPECT_GT(limit.bytes, 0u);
  EXPECT_LE(limit.bytes, physical);
  EXPECT_EQ(limit.limited, limit.bytes < physical);
}

}  // namespace
}  // namespace gaussmesh::stream
