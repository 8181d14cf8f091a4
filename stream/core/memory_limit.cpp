// The memory this process may use. See memory_limit.h.
#include "stream/core/memory_limit.h"

#include <sys/resource.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

namespace gaussmesh::stream {
namespace {

// A limit file's value: a byte count, or "max" (v2) / a value near 2^63 (v1) for none.
std::uint64_t read_limit(const std::string& path) {
  std::ifstream in(path);
  std::string text;
  if (!(in >> text) || text == "max") return 0;
  std::uint64_t value = 0;
  for (char c : text) {
    if (c < '0' || c > '9' || value > (UINT64_MAX - 9) / 10) return 0;
    value = value * 10 + std::uint64_t(c - '0');
  }
  return value >= (std::uint64_t{1} << 62) ? 0 : value;
}

// The least limit named `file` in `dir` + `group` and each of its parents up to `dir` itself.
std::uint64_t least_up_the_tree(const std::string& dir, std::string group, const char* file) {
  std::uint64_t least = 0;
  for (;;) {
    const std::uint64_t limit = read_limit(dir + group + "/" + file);
    if (limit != 0 && (least == 0 || limit < least)) least = limit;
    if (group.empty() || group == "/") break;
    const std::size_t slash = group.rfind('/');
    group = slash == std::string::npos ? std::string() : group.substr(0, slash);
  }
  return least;
}

void take(MemoryLimit& into, std::uint64_t bytes, const char* by) {
  if (bytes != 0 && (into.bytes == 0 || bytes < into.bytes)) into = {bytes, true, by};
}

}  // namespace

std::uint64_t cgroup_memory_limit(std::string_view proc_cgroup, const std::string& mount_root) {
  std::uint64_t least = 0;
  const auto keep = [&](std::uint64_t limit) {
    if (limit != 0 && (least == 0 || limit < least)) least = limit;
  };
  std::istringstream lines{std::string(proc_cgroup)};
  for (std::string line; std::getline(lines, line);) {
    // hierarchy-id:controller,controller:/path
    const std::size_t a = line.find(':'), b = a == std::string::npos ? a : line.find(':', a + 1);
    if (b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1), group = line.substr(b + 1);
    if (group.empty() || group[0] != '/' || group.find("..") != std::string::npos) continue;
    if (line.compare(0, a, "0") == 0 && controllers.empty()) {  // v2: one unified hierarchy
      keep(least_up_the_tree(mount_root, group, "memory.max"));
      keep(least_up_the_tree(mount_root + "/unified", group, "memory.max"));
    } else if (("," + controllers + ",").find(",memory,") != std::string::npos) {  // v1
      keep(least_up_the_tree(mount_root + "/memory", group, "memory.limit_in_bytes"));
    }
  }
  return least;
}

MemoryLimit process_memory_limit() {
  MemoryLimit limit;
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) limit.bytes = std::uint64_t(pages) * std::uint64_t(page);
  std::ifstream in("/proc/self/cgroup");
  std::stringstream text;
  text << in.rdbuf();
  take(limit, cgroup_memory_limit(text.str(), "/sys/fs/cgroup"), "cgroup memory limit");
  for (const auto& [resource, name] : {std::pair{RLIMIT_AS, "RLIMIT_AS"}, std::pair{RLIMIT_DATA, "RLIMIT_DATA"}}) {
    rlimit r{};
    if (::getrlimit(resource, &r) == 0 && r.rlim_cur != RLIM_INFINITY) take(limit, std::uint64_t(r.rlim_cur), name);
  }
  return limit;
}

}  // namespace gaussmesh::stream
