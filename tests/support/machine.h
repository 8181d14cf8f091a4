// What the benchmarks read off the machine they run on: /proc/meminfo fields, a file's first line
// (/proc/loadavg), the free space of a directory's file system.
#pragma once

#include <filesystem>
#include <string>

namespace gaussmesh::testing {

// A /proc/meminfo field such as "MemAvailable:", in MB (10^6 bytes); 0 if absent.
double meminfo_mb(const char* key);
// The first line of a file ("" if unreadable).
std::string first_line(const char* path);
// Free space for an unprivileged writer on dir's file system, in GB (10^9 bytes); 0 on error.
double free_disk_gb(const std::filesystem::path& dir);

}  // namespace gaussmesh::testing
