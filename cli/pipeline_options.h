// The out-of-core options shared by `sample` and (later) `simplify` (DESIGN §5): --memory SIZE,
// --threads N, --tmp DIR; their parsing; and the progress line on stderr.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

#include "format/status.h"

namespace gaussmesh::cli {

struct PipelineOptions {
  std::string memory;        // "" = in core; else SIZE with an optional K, M or G suffix (powers of 2)
  std::uint32_t threads = 0;  // 0 = every core
  std::string tmp;            // "" = $TMPDIR, else /tmp
};

void add_pipeline_options(CLI::App& sub, PipelineOptions& options);

// "64M" -> 67108864. Errors (kUsage): not a number, an unknown suffix, zero, or overflow.
format::Result<std::uint64_t> parse_memory_size(const std::string& text);

// Threads to use: options.threads, or the machine's cores when 0.
std::uint32_t pipeline_threads(const PipelineOptions& options);

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
  void update(const char* pass, std::size_t done, std::size_t total, std::uint64_t triangles);

 private:
  bool enabled_ = false, dirty_ = false;
  std::string pass_;
  std::chrono::steady_clock::time_point pass_start_, last_print_;
};

}  // namespace gaussmesh::cli
