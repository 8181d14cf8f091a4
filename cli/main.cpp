// gaussmesh: command-line entry point. Exit codes: 0 ok, 1 usage, 2 bad input,
// 3 processing, 4 output/temp write, 5 resources (docs/cli.md).
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <exception>
#include <new>
#ifdef __GLIBC__
#include <malloc.h>
#include <sys/resource.h>
#endif

#include <CLI/CLI.hpp>

#include "cli/commands.h"

namespace gaussmesh::cli {
namespace {
int g_verbosity = 1;
}

int verbosity() { return g_verbosity; }
void set_verbosity(int level) { g_verbosity = level; }

int report_error(const Status& status) {
  std::fprintf(stderr, "gaussmesh: %s\n", status.to_string().c_str());
  return static_cast<int>(status.code());
}

void add_common_flags(CLI::App& sub, CommonFlags& flags, const char* verbose_help) {
  sub.add_option("--report", flags.report, "Write the figures as JSON to FILE ('-': stdout)");
  sub.add_flag("-q,--quiet", flags.quiet, "Print nothing on stderr but errors");
  sub.add_flag("-v,--verbose", flags.verbose, verbose_help);
}

void apply_verbosity(const CommonFlags& flags) {
  if (flags.quiet) set_verbosity(0);
  if (flags.verbose) set_verbosity(2);
}

int finish(const CommonFlags& flags, const std::string& report_json) {
  if (flags.report.empty()) return 0;
  if (Status s = write_report(flags.report, report_json); !s) return report_error(s);
  return 0;
}

}  // namespace gaussmesh::cli

int main(int argc, char** argv) {
  using namespace gaussmesh;
  install_signal_cleanup();
  // A write past the file-size limit (ulimit -f) fails with EFBIG, reported and cleaned up as a
  // full disk is, instead of SIGXFSZ killing the process with its temporary files left behind.
  ::signal(SIGXFSZ, SIG_IGN);
#ifdef __GLIBC__
  // One malloc arena for every thread: the chunk passes allocate and free each chunk's arrays on
  // several threads, and with an arena per thread one thread's free pages are never reused by
  // another, which lifts the streaming passes' peak over the budget.
  ::mallopt(M_ARENA_MAX, 1);
  // Blocks of 2 MiB and more come from mmap and go back to the system when freed; glibc would
  // otherwise raise the threshold after the first such free, and the stitch's large tables
  // would then stay resident after use. Smaller blocks (the per-chunk arrays) stay on the heap,
  // where reuse is cheap.
  ::mallopt(M_MMAP_THRESHOLD, 2 << 20);
  ::mallopt(M_TRIM_THRESHOLD, 4 << 20);
#endif
  // The open-file limit up to its hard limit: the partition keeps a descriptor per chunk file
  // open when the limit leaves room, else it reopens the file for every frame.
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
  cli::register_view(app, run);
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
    return static_cast<int>(Code::kUsage);
  }
  try {
    return run ? run() : static_cast<int>(Code::kUsage);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "gaussmesh: out of memory\n");
    return static_cast<int>(Code::kResources);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gaussmesh: internal error: %s\n", e.what());
    return static_cast<int>(Code::kProcessing);
  }
}
