// The resource options of the jobs that stream (sample, simplify): --memory SIZE|auto,
// --engine auto|in-core|out-of-core, --threads N, --tmp DIR; their parsing; and the progress
// line on stderr.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

#include "gaussmesh/gaussmesh.h"

namespace gaussmesh::cli {

struct ResourceFlags {
  std::string memory = "auto";  // SIZE with an optional K, M or G suffix (powers of 2), or auto
  std::string engine = "auto";
  std::uint32_t threads = 0;    // 0 = every core
  std::string tmp;              // "" = $TMPDIR, else /tmp
};

void add_resource_options(CLI::App& sub, ResourceFlags& flags);

// "64M" -> 67108864, "auto" -> 0. Errors (kUsage): not a number, an unknown suffix, zero, or overflow.
Result<std::uint64_t> parse_memory_size(const std::string& text);

// The flags as API options (the progress callback is the caller's).
Result<ResourceOptions> resource_options(const ResourceFlags& flags);

// One status line on stderr, rewritten in place ("\r"), only when stderr is a terminal and the
// verbosity is not 0 (-q): pass name, percent, M triangles/s and the time left. Ends the line
// on destruction.
class Progress {
 public:
  Progress();
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  // done of total units of `pass`, which covers `triangles` input triangles in all.
  void update(const char* pass, std::uint64_t done, std::uint64_t total, std::uint64_t triangles);
  ProgressFn callback() {
    return [this](const char* pass, std::uint64_t done, std::uint64_t total, std::uint64_t triangles) {
      update(pass, done, total, triangles);
    };
  }

 private:
  bool enabled_ = false, dirty_ = false;
  std::string pass_;
  std::chrono::steady_clock::time_point pass_start_, last_print_;
};

}  // namespace gaussmesh::cli
