#include "tests/support/machine.h"

#include <sys/statvfs.h>

#include <cstdlib>
#include <cstring>
#include <fstream>

namespace gaussmesh::testing {

double meminfo_mb(const char* key) {
  std::ifstream in("/proc/meminfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) == 0) return std::strtod(line.c_str() + std::strlen(key), nullptr) * 1024 / 1e6;
  }
  return 0;
}

std::string first_line(const char* path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

double free_disk_gb(const std::filesystem::path& dir) {
  struct statvfs info {};
  return ::statvfs(dir.c_str(), &info) == 0 ? double(info.f_bavail) * double(info.f_frsize) / 1e9 : 0;
}

}  // namespace gaussmesh::testing
