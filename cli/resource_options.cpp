// --memory / --engine / --threads / --tmp, and the progress line. See resource_options.h.
#include "cli/resource_options.h"

#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <limits>

#include "cli/commands.h"

namespace gaussmesh::cli {

void add_resource_options(CLI::App& sub, ResourceFlags& flags) {
  sub.add_option("--memory", flags.memory,
                 "Working-memory budget: SIZE (K, M, G suffixes; at least 16M) or auto (docs/cli.md)")
      ->capture_default_str();
  sub.add_option("--engine", flags.engine, "auto (from the budget and the input size), in-core or out-of-core")
      ->capture_default_str();
  sub.add_option("--threads", flags.threads, "Chunks processed at once (0: one per core)")->capture_default_str();
  sub.add_option("--tmp", flags.tmp, "Directory for temporary files (default: $TMPDIR, else /tmp)");
}

Result<std::uint64_t> parse_memory_size(const std::string& text) {
  if (text == "auto") return std::uint64_t{0};
  auto bad = [&](const std::string& why) {
    return Status::error(Code::kUsage, "--memory", "'" + text + "': " + why);
  };
  std::size_t i = 0;
  std::uint64_t value = 0;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
    const std::uint64_t digit = static_cast<std::uint64_t>(text[i] - '0');
    if (value > (std::numeric_limits<std::uint64_t>::max() - digit) / 10) return bad("too large");
    value = value * 10 + digit;
    ++i;
  }
  if (i == 0) return bad("expected a number with an optional K, M or G suffix");
  int shift = 0;
  if (i < text.size()) {
    const char s = static_cast<char>(std::toupper(static_cast<unsigned char>(text[i])));
    shift = s == 'K' ? 10 : s == 'M' ? 20 : s == 'G' ? 30 : -1;
    if (shift < 0) return bad("unknown suffix (use K, M or G)");
    ++i;
    if (i < text.size() && (text[i] == 'B' || text[i] == 'b' || text[i] == 'i')) ++i;
    if (i < text.size() && (text[i] == 'B' || text[i] == 'b')) ++i;
  }
  if (i != text.size()) return bad("trailing characters");
  if (value == 0) return bad("must be positive");
  if (value > (std::numeric_limits<std::uint64_t>::max() >> shift)) return bad("too large");
  return value << shift;
}

Result<ResourceOptions> resource_options(const ResourceFlags& flags) {
  auto memory = parse_memory_size(flags.memory);
  if (!memory) return memory.status();
  ResourceOptions options;
  options.memory_bytes = *memory;
  if (flags.engine == "auto") options.engine = Engine::kAuto;
  else if (flags.engine == "in-core") options.engine = Engine::kInCore;
  else if (flags.engine == "out-of-core") options.engine = Engine::kOutOfCore;
  else return Status::error(Code::kUsage, "--engine", "expected auto, in-core or out-of-core, got '" + flags.engine + "'");
  options.threads = flags.threads;
  options.tmp_dir = flags.tmp;
  return options;
}

Progress::Progress() : enabled_(verbosity() > 0 && ::isatty(2) == 1) {}

Progress::~Progress() {
  if (dirty_) std::fputc('\n', stderr);
}

void Progress::update(const char* pass, std::uint64_t done, std::uint64_t total, std::uint64_t triangles) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (pass_ != pass) {
    if (dirty_) std::fputc('\n', stderr);
    pass_ = pass;
    pass_start_ = now;
    last_print_ = {};
  }
  if (done < total && now - last_print_ < std::chrono::milliseconds(200)) return;
  last_print_ = now;
  const double seconds = std::chrono::duration<double>(now - pass_start_).count();
  const double fraction = total == 0 ? 1.0 : double(done) / double(total);
  const double rate = seconds > 0 ? fraction * double(triangles) / seconds / 1e6 : 0;
  const double left = fraction > 0 ? seconds * (1 - fraction) / fraction : 0;
  std::fprintf(stderr, "\rgaussmesh: %s %5.1f %%  %.1f M triangles/s  ETA %.0f s   ", pass, 100 * fraction, rate, left);
  std::fflush(stderr);
  dirty_ = true;
}

}  // namespace gaussmesh::cli
