// Running a program as a child process for the benchmarks, so that its peak RSS (wait4's
// ru_maxrss) and CPU time are its own, and reading the "key=value" lines such children print.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace gaussmesh::testing {

struct ChildRun {
  int exit_code = -1;      // exit status, or 128 + signal; -1 when fork failed
  double seconds = 0;      // wall
  double cpu_seconds = 0;  // user + system of the child
  double peak_rss_mb = 0;  // ru_maxrss of the child
  std::string out;         // its standard output
};

// Runs argv[0] (looked up on PATH when it has no '/') with argv, no shell; stdout goes to
// stdout_file and is read back into out, stderr is appended to log.
ChildRun run_child(const std::vector<std::string>& argv, const std::filesystem::path& stdout_file,
                   const std::filesystem::path& log);

// The "key=value" tokens of a line (other tokens are skipped).
std::map<std::string, std::string> parse_pairs(const std::string& line);

}  // namespace gaussmesh::testing
