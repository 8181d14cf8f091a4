// gaussmesh: command-line entry point. Exit codes: 0 ok, 1 usage, 2 bad input,
// 3 processing, 4 output/temp write, 5 resources (docs/cli.md).
#include <algorithm>
#include <cstdio>
#include <exception>
#include <new>
#ifdef __GLIBC__
#include <malloc.h>
#include <sys/resource.h>
#endif

#include <CLI/CLI.hpp>

#include "cli/commands.h"
#include "format/temp_registry.h"

namespace gaussmesh::cli {
namespace {
int g_verbosity = 1;
}

int verbosity() { return g_verbosity; }
void set_verbosity(int level) { g_verbosity = level; }

int report_error(const format::Status& status) {
  std::fprintf(stderr, "gaussmesh: %s\n", status.to_string().c_str());
  return static_cast<int>(status.code());
}

}  // namespace gaussmesh::cli

int main(int argc, char** argv) {
  using namespace gaussmesh;
  format::install_signal_cleanup();
#ifdef __GLIBC__
  // One malloc arena for every thread. The chunk passes allocate and free each chunk's arrays
  // on two threads; with an arena per thread the free pages of one were never reused by the
  // other, and at 100M triangles under --memory 64M the passes after the partition peaked
  // 3-9 MB above it (65-73 MB against 63.8 MB with one arena). Measured: no CPU cost at 1M
  // (in core) or 10M (out of core) — the threads' small allocations go through glibc's
  // per-thread caches, the large ones are a few per chunk.
  ::mallopt(M_ARENA_MAX, 1);
  // Blocks of 2 MiB and more come from mmap and go back to the system when freed. glibc's
  // default threshold rises to 32 MiB once such a block is freed, after which the stitch's
  // tables and the piece join's buckets came from the heap and stayed resident after use
  // (100M triangles under 64 MiB: the merge peaked at 52 instead of 48 MiB). Below 2 MiB (pass
  // A's per-chunk arrays) nothing changes; at 1 MiB the 100M run took 7x the page faults.
  ::mallopt(M_MMAP_THRESHOLD, 2 << 20);
  ::mallopt(M_TRIM_THRESHOLD, 4 << 20);
#endif
  // The open-file limit up to its hard limit (Debian's shells start at 1,024 of 524,288): the
  // partition keeps a descriptor per chunk file open only when the limit leaves room, else it
  // reopens the file for every frame (100M triangles, 1,464 chunks: ~0.9M opens and closes).
  rlimit files{};
  if (::getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur < files.rlim_max) {
    files.rlim_cur = std::min<rlim_t>(files.rlim_max, rlim_t{1} << 20);
    ::setrlimit(RLIMIT_NOFILE, &files);
  }
  CLI::App app{"gaussmesh: feature-sensitive simplification of meshes larger than memory"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "gaussmesh 0.1.0");
  cli::Runner run;
  cli::register_info(app, run);
  cli::register_sample(app, run);
  cli::register_simplify(app, run);
  cli::register_compare(app, run);
  cli::register_segment(app, run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "gaussmesh: usage: %s\n", e.what());
    return static_cast<int>(format::Code::kUsage);
  }
  try {
    return run ? run() : static_cast<int>(format::Code::kUsage);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "gaussmesh: out of memory\n");
    return static_cast<int>(format::Code::kResources);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gaussmesh: internal error: %s\n", e.what());
    return static_cast<int>(format::Code::kProcessing);
  }
}
