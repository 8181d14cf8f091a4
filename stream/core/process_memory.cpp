// The process's resident set and the allocator's free pages. See process_memory.h.
#include "stream/core/process_memory.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <cinttypes>
#include <cstdio>

#include <sys/resource.h>
#include <unistd.h>

namespace gaussmesh::stream {

// VmHWM, the high-water mark of this process image's own memory: getrusage's ru_maxrss carries
// over exec, so a process started by a large parent (a Python pipeline holding gigabytes) would
// start with the parent's peak. getrusage only where /proc is missing (a bare chroot).
std::uint64_t peak_rss() {
  if (std::FILE* f = std::fopen("/proc/self/status", "re")) {
    char line[256];
    std::uint64_t kib = 0;
    bool found = false;
    while (std::fgets(line, sizeof line, f) != nullptr) {
      if (std::sscanf(line, "VmHWM: %" SCNu64 " kB", &kib) == 1) {
        found = true;
        break;
      }
    }
    std::fclose(f);
    if (found) return kib * 1024;
  }
  rusage usage{};
  return ::getrusage(RUSAGE_SELF, &usage) == 0 ? static_cast<std::uint64_t>(usage.ru_maxrss) * 1024 : 0;
}

std::uint64_t current_rss() {
  std::uint64_t pages = 0, resident = 0;
  if (std::FILE* f = std::fopen("/proc/self/statm", "re")) {
    if (std::fscanf(f, "%" SCNu64 " %" SCNu64, &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return resident * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
}

void release_free_memory() {
#ifdef __GLIBC__
  ::malloc_trim(0);
#endif
}

}  // namespace gaussmesh::stream
