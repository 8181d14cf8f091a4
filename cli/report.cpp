// JSON reports and process figures.
#include "cli/report.h"

#include <fstream>
#include <string>

#include "format/output_file.h"

namespace gaussmesh::cli {

format::Status write_report(const std::string& path, const Json& report) {
  auto out = format::OutputFile::create(path, false);
  if (!out) return out.status();
  std::string text = report.dump(2);
  text.push_back('\n');
  GM_RETURN_IF_ERROR((*out)->write(text));
  return (*out)->commit();
}

std::uint64_t peak_rss_bytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) {
      return std::stoull(line.substr(6)) * 1024;
    }
  }
  return 0;
}

}  // namespace gaussmesh::cli
