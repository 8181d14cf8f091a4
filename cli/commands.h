// Subcommand registration: each cmd_*.cpp adds its subcommand and sets `run` when chosen.
#pragma once

#include <functional>

#include <CLI/CLI.hpp>

#include "gaussmesh/gaussmesh.h"

namespace gaussmesh::cli {

// Returns the process exit code (gaussmesh::Code values; 0 on success).
using Runner = std::function<int()>;

void register_info(CLI::App& app, Runner& run);
void register_sample(CLI::App& app, Runner& run);
void register_simplify(CLI::App& app, Runner& run);
void register_compare(CLI::App& app, Runner& run);
void register_segment(CLI::App& app, Runner& run);
void register_view(CLI::App& app, Runner& run);

// Prints "gaussmesh: <where>: <message>" on stderr and returns the exit code for status.
int report_error(const Status& status);

// Global verbosity: -q sets 0, default 1, -v sets 2.
int verbosity();
void set_verbosity(int level);

// The flags every subcommand takes: --report FILE|-, -q, -v.
struct CommonFlags {
  std::string report;
  bool quiet = false;
  bool verbose = false;
};
void add_common_flags(CLI::App& sub, CommonFlags& flags, const char* verbose_help);
// Sets the verbosity from -q / -v.
void apply_verbosity(const CommonFlags& flags);
// Writes report_json to --report when given; the exit code (0, or the write's error).
int finish(const CommonFlags& flags, const std::string& report_json);

}  // namespace gaussmesh::cli
