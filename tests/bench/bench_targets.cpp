// Benchmark of `gaussmesh simplify --ratio R` (the face target: the Gauss approximation finished
// by QEM collapses) against meshoptimizer at the same face count: for every input and ratio it
// runs, each as a child process (wall seconds and peak RSS from wait4's rusage),
//   1. gaussmesh simplify IN -o OUT.ply --format ply --ratio R --report J [EXTRA...], and reads
//      the report (target_faces, output_faces, stopped_by);
//   2. meshopt_file IN --target-faces F, then with --sloppy (meshopt_simplify and
//      meshopt_simplifySloppy, reading and writing included), F = gaussmesh's output_faces;
//   3. gaussmesh compare IN OUT --report - after each, for Hausdorff and RMS in % of the input's
//      bounding-box diagonal, and the share of the output's area that faces away from the input
//      (folds and flipped faces),
// and prints one markdown table on stdout, then per ratio how gaussmesh's Hausdorff and RMS
// compare with meshopt_simplify's (gaussmesh / meshopt: the worst and the median over the
// inputs, and on how many inputs gaussmesh's Hausdorff is not larger). The command line is
// printed above the table; progress goes to stderr. Not a timed test.
//
//   bench_targets [--ratios R,R,...] [--sizes N,N,...|none] [--large] [--sources cow,torus,...]
//                 [--no-fixtures] [--no-scattered] [--dir D] [--keep] [--no-meshopt]
//                 [--compare-max N] [--samples N] [--gaussmesh PATH] [-- EXTRA SIMPLIFY ARGS...]
//
// Ratios default to 0.5,0.1,0.01,0.001. Inputs: the repository's fixtures/real/*.off and *.ply
// (unless --no-fixtures), then for each of --sizes (default 1000000; --large adds 10000000 and
// 100000000; `none`: no generated input) and each of --sources (default cow,torus; any
// make_large_mesh --source) a binary PLY from make_large_mesh in its own coherent vertex order,
// then (unless --no-scattered) its scattered copy from scatter_mesh (vertex ids and face order
// shuffled, seed 7: make_large_mesh has no shuffle option). Generated inputs are made in a fresh
// run-XXXXXX directory under --dir (default /var/tmp/gaussmesh-bench-targets), one source and
// size at a time, and deleted when their rows are done unless --keep (outputs are always
// deleted); the run directory is removed at the end, except its log.txt (the children's stderr)
// when a child failed.
// Arguments after `--` go to `gaussmesh simplify` unchanged (e.g. `-- --memory 64M`).
//
// What is skipped, and why:
//   - a generated input whose PLY (~19 bytes a triangle), its scattered copy and the largest
//     output would not fit in the free disk of --dir;
//   - a scattered copy whose ~40 bytes a triangle (scatter_mesh holds the whole mesh) pass 85 %
//     of MemAvailable;
//   - compare above --compare-max input triangles (default 20M): it holds both meshes and
//     measures every input vertex and edge midpoint (~3 s at 1M triangles); the cells say –;
//   - a meshopt run whose predicted peak RSS passes 85 % of MemAvailable, as in bench_pipeline:
//     extrapolated linearly in input triangles from the same tool's largest earlier run of at
//     least 1M triangles, else 16 MB + 160 bytes a triangle (meshopt_file measured 127 MB for
//     meshopt_simplify, 51 MB for the sloppy one, on the 980,876-triangle refined cow); the row
//     says so;
//   - every meshopt row with --no-meshopt.
// A run that fails gets a row saying so, with its exit code and its last stderr line (e.g.
// meshopt_simplifySloppy's "no faces left" at a handful of faces); the other runs go on.
// "within 1 %" is |output_faces − target_faces| ≤ 1 % of target_faces, gaussmesh rows only: a
// small target can miss it by a face or two (a collapse removes two faces), or stop above it
// when every further collapse would change the topology (stopped_by topology).
// --samples is passed to compare (default: compare's own); --gaussmesh runs another build of the
// tool (default: the one built beside this program).
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/support/child_process.h"
#include "tests/support/machine.h"
#include "tests/support/test_util.h"

namespace gaussmesh::bench {
namespace {

namespace fs = std::filesystem;

using testing::ChildRun;
using testing::first_line;
using testing::free_disk_gb;
using testing::meminfo_mb;
using testing::parse_pairs;
using testing::run_child;

constexpr double kPlyBytesPerTriangle = 19;  // binary PLY: 13 a face, ~6 a vertex
constexpr double kMeshoptPriorBaseMb = 16, kMeshoptPriorBytesPerTriangle = 160;
constexpr std::uint64_t kExtrapolateFrom = 1'000'000;  // triangles: below, the fixed cost dominates RSS
constexpr double kMemoryShare = 0.85;                   // of MemAvailable
constexpr double kScatterBytesPerTriangle = 40;          // scatter_mesh: the mesh and its renumbering
const char* const kNone = "–";

const char* const kGaussmesh = "gaussmesh";
const char* const kMeshopt = "meshopt_simplify";
const char* const kSloppy = "meshopt_simplifySloppy";

struct Options {
  std::vector<std::string> ratios = {"0.5", "0.1", "0.01", "0.001"};
  std::vector<std::uint64_t> sizes = {1'000'000};
  std::vector<std::string> sources = {"cow", "torus"};
  fs::path dir = "/var/tmp/gaussmesh-bench-targets";
  bool fixtures = true, scattered = true, keep = false, meshopt = true;
  std::uint64_t compare_max = 20'000'000;
  std::string samples;  // empty: compare's default
  std::string gaussmesh = testing::gaussmesh_binary();
  std::vector<std::string> extra;  // after `--`, to gaussmesh simplify
};

struct Row {
  std::string input;
  std::uint64_t input_faces = 0;
  std::string ratio;
  std::string tool;
  std::uint64_t target = 0;
  std::string note;  // set when the run was skipped or failed
  std::uint64_t output_faces = 0;
  std::optional<bool> within;  // gaussmesh rows
  std::string stopped_by;      // gaussmesh rows
  std::optional<double> hausdorff_pct, rms_pct;
  std::optional<double> facing_away_pct;  // of the output's area: faces turned against the input
  double seconds = 0, peak_rss_mib = 0;
};

std::string fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

// The value as a shell word: quoted when it holds anything but [A-Za-z0-9_./,:=%+-].
std::string shell_word(const std::string& word) {
  const bool plain = !word.empty() && std::all_of(word.begin(), word.end(), [](unsigned char c) {
    return std::isalnum(c) || std::strchr("_./,:=%+-", c) != nullptr;
  });
  if (plain) return word;
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

// 1000000 -> "1M", 10000000 -> "10M", 2500 -> "2500".
std::string size_label(std::uint64_t n) {
  if (n >= 1'000'000 && n % 1'000'000 == 0) return std::to_string(n / 1'000'000) + "M";
  if (n >= 1'000 && n % 1'000 == 0) return std::to_string(n / 1'000) + "k";
  return std::to_string(n);
}

std::optional<nlohmann::json> parse_json(const std::string& text) {
  try {
    return nlohmann::json::parse(text);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

std::optional<nlohmann::json> read_json(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  return parse_json(text.str());
}

// The face count a PLY or OFF header declares (0 when it cannot tell; the report says later).
std::uint64_t header_faces(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  if (!std::getline(in, line)) return 0;
  if (line.rfind("ply", 0) == 0) {
    for (int lines = 0; lines < 1000 && std::getline(in, line) && line.rfind("end_header", 0) != 0; ++lines) {
      if (line.rfind("element face ", 0) == 0) return std::strtoull(line.c_str() + 13, nullptr, 10);
    }
    return 0;
  }
  if (line.rfind("OFF", 0) == 0) {
    std::string counts = line.substr(3);
    while (counts.find_first_not_of(" \t\r") == std::string::npos && std::getline(in, line)) {
      if (!line.empty() && line[0] != '#') counts = line;
    }
    std::istringstream fields(counts);
    std::uint64_t vertices = 0, faces = 0;
    return fields >> vertices >> faces ? faces : 0;
  }
  return 0;
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

std::vector<std::string> split(const std::string& list) {
  std::vector<std::string> items;
  std::istringstream in(list);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

// The meshopt runs' memory guard: each tool's largest run so far predicts the next.
class MemoryGuard {
 public:
  void record(const std::string& tool, std::uint64_t faces, double peak_rss_mb) {
    auto& largest = largest_[tool];
    if (faces >= largest.first) largest = {faces, peak_rss_mb};
  }
  // "" when the predicted peak RSS fits in 85 % of MemAvailable, else why the run is skipped.
  std::string refusal(const std::string& tool, std::uint64_t faces) const {
    double predicted = kMeshoptPriorBaseMb + double(faces) * kMeshoptPriorBytesPerTriangle / 1e6;
    const auto it = largest_.find(tool);
    if (it != largest_.end() && it->second.first >= kExtrapolateFrom) {
      predicted = it->second.second * double(faces) / double(it->second.first);
    }
    const double available = meminfo_mb("MemAvailable:");
    if (predicted <= kMemoryShare * available) return "";
    return "skipped: ~" + fixed(predicted / 1000, 1) + " GB predicted peak RSS, " + fixed(available / 1000, 1) +
           " GB available";
  }

 private:
  std::map<std::string, std::pair<std::uint64_t, double>> largest_;  // tool -> (faces, peak RSS MB)
};

struct Input {
  std::string label;
  fs::path path;
  std::uint64_t faces = 0;  // from the header; gaussmesh's report corrects it
};

// Runs one input at every ratio and appends its rows.
class Runner {
 public:
  Runner(const Options& options, const fs::path& work, const std::string& meshopt)
      : options_(options), work_(work), log_(work / "log.txt"), meshopt_(meshopt) {}

  const fs::path& log() const { return log_; }
  int failures() const { return failures_; }
  const std::vector<Row>& rows() const { return rows_; }
  void add_note_row(const Row& row) { rows_.push_back(row); }
  void count_failure() { ++failures_; }

  // "failed (exit N: the child's last stderr line)": the log grows by what the run wrote from its size before.
  std::string failure(int exit_code, std::uintmax_t log_before) const {
    std::ifstream in(log_, std::ios::binary);
    in.seekg(std::streamoff(log_before));
    std::string line, last;
    while (std::getline(in, line)) {
      if (!line.empty()) last = line;
    }
    std::replace(last.begin(), last.end(), '|', '/');  // a table cell
    return "failed (exit " + std::to_string(exit_code) + (last.empty() ? "" : ": " + last) + ")";
  }

  std::uintmax_t log_size() const {
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(log_, ec);
    return ec ? 0 : size;
  }

  void run(Input& input) {
    for (const std::string& ratio : options_.ratios) {
      Row row = simplify(input, ratio);
      const std::uint64_t target = row.note.empty()
          ? std::max<std::uint64_t>(1, row.output_faces)
          : std::max<std::uint64_t>(1, std::uint64_t(std::llround(double(input.faces) * std::stod(ratio))));
      rows_.push_back(row);
      if (!options_.meshopt) continue;
      for (bool sloppy : {false, true}) rows_.push_back(meshopt(input, ratio, target, sloppy));
    }
  }

 private:
  Row simplify(Input& input, const std::string& ratio) {
    Row row{input.label, input.faces, ratio, kGaussmesh};
    const fs::path out = work_ / "gaussmesh.ply", report = work_ / "simplify.json";
    std::vector<std::string> cmd = {options_.gaussmesh, "simplify", input.path.string(), "-o", out.string(),
                                    "--format", "ply", "--ratio", ratio, "--report", report.string()};
    cmd.insert(cmd.end(), options_.extra.begin(), options_.extra.end());
    const std::uintmax_t log_before = log_size();
    const ChildRun r = run_child(cmd, work_ / "simplify.out", log_);
    const auto json = read_json(report);
    if (r.exit_code != 0 || !json) {
      row.note = failure(r.exit_code, log_before);
      ++failures_;
    } else {
      input.faces = json->value("input_faces", input.faces);
      row.input_faces = input.faces;
      row.target = json->value("target_faces", std::uint64_t{0});
      row.output_faces = json->value("output_faces", std::uint64_t{0});
      row.stopped_by = json->value("stopped_by", std::string("?"));
      row.within = std::abs(double(row.output_faces) - double(row.target)) <= 0.01 * double(row.target);
      row.seconds = r.seconds;
      row.peak_rss_mib = r.peak_rss_mb * 1e6 / 1048576;
      compare(row, input, out);
      const std::string how = ", frequency " + std::to_string(json->value("gauss_frequency", 0)) +
                              (json->value("out_of_core", false) ? ", out of core" : ", in core");
      progress(row, how.c_str());
    }
    fs::remove(out);
    fs::remove(report);
    return row;
  }

  Row meshopt(const Input& input, const std::string& ratio, std::uint64_t target, bool sloppy) {
    Row row{input.label, input.faces, ratio, sloppy ? kSloppy : kMeshopt, target};
    row.note = guard_.refusal(row.tool, input.faces);
    if (!row.note.empty()) {
      std::fprintf(stderr, "bench_targets: %s ratio %s %s: %s\n", input.label.c_str(), ratio.c_str(), row.tool.c_str(),
                   row.note.c_str());
      return row;
    }
    const fs::path out = work_ / "meshopt.ply";
    std::vector<std::string> cmd = {meshopt_, input.path.string(), "--target-faces", std::to_string(target), "-o",
                                    out.string()};
    if (sloppy) cmd.push_back("--sloppy");
    const std::uintmax_t log_before = log_size();
    const ChildRun r = run_child(cmd, work_ / "meshopt.out", log_);
    auto pairs = parse_pairs(r.out);
    if (r.exit_code != 0 || !pairs.count("output_faces")) {
      row.note = failure(r.exit_code, log_before);
      ++failures_;
    } else {
      row.output_faces = std::strtoull(pairs["output_faces"].c_str(), nullptr, 10);
      row.seconds = r.seconds;
      row.peak_rss_mib = r.peak_rss_mb * 1e6 / 1048576;
      guard_.record(row.tool, input.faces, r.peak_rss_mb);
      compare(row, input, out);
      progress(row, "");
    }
    fs::remove(out);
    return row;
  }

  void compare(Row& row, const Input& input, const fs::path& output) {
    if (input.faces > options_.compare_max) return;
    std::vector<std::string> cmd = {options_.gaussmesh, "compare", input.path.string(), output.string(), "--report",
                                    "-", "-q"};
    if (!options_.samples.empty()) cmd.insert(cmd.end(), {"--samples", options_.samples});
    const std::uintmax_t log_before = log_size();
    const ChildRun c = run_child(cmd, work_ / "compare.out", log_);
    const auto json = parse_json(c.out);
    if (c.exit_code != 0 || !json || !json->contains("hausdorff_pct")) {
      std::fprintf(stderr, "bench_targets: compare %s %s: %s\n", input.label.c_str(), row.tool.c_str(),
                   failure(c.exit_code, log_before).c_str());
      ++failures_;
      return;
    }
    row.hausdorff_pct = json->value("hausdorff_pct", -1.0);
    row.rms_pct = json->value("rms_pct", -1.0);
    if (json->contains("b_to_a")) row.facing_away_pct = (*json)["b_to_a"].value("facing_away_area_pct", -1.0);
    fs::remove(work_ / "compare.out");
  }

  static void progress(const Row& row, const char* how) {
    std::fprintf(stderr, "bench_targets: %s ratio %s %s: %llu -> %llu faces (target %llu), %.2f s, %.0f MiB%s%s\n",
                 row.input.c_str(), row.ratio.c_str(), row.tool.c_str(), (unsigned long long)row.input_faces,
                 (unsigned long long)row.output_faces, (unsigned long long)row.target, row.seconds, row.peak_rss_mib,
                 how, row.hausdorff_pct ? (", Hausdorff " + fixed(*row.hausdorff_pct, 3) + " %").c_str() : "");
  }

  const Options& options_;
  fs::path work_, log_;
  std::string meshopt_;
  MemoryGuard guard_;
  std::vector<Row> rows_;
  int failures_ = 0;
};

void print_table(const std::vector<Row>& rows) {
  std::printf("| input | input faces | ratio | tool | target | output faces | within 1 %% | stopped_by "
              "| Hausdorff %% | RMS %% | facing away, %% of area | seconds | peak RSS MiB |\n");
  std::printf("| --- | ---: | ---: | --- | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: |\n");
  for (const Row& r : rows) {
    const std::string target = r.target ? std::to_string(r.target) : "";
    if (!r.note.empty()) {
      std::printf("| %s | %llu | %s | %s | %s | %s | | | | | | | |\n", r.input.c_str(), (unsigned long long)r.input_faces,
                  r.ratio.c_str(), r.tool.c_str(), target.c_str(), r.note.c_str());
      continue;
    }
    std::printf("| %s | %llu | %s | %s | %s | %llu | %s | %s | %s | %s | %s | %s | %s |\n", r.input.c_str(),
                (unsigned long long)r.input_faces, r.ratio.c_str(), r.tool.c_str(), target.c_str(),
                (unsigned long long)r.output_faces, r.within ? (*r.within ? "yes" : "no") : "",
                r.stopped_by.c_str(), r.hausdorff_pct ? fixed(*r.hausdorff_pct, 3).c_str() : kNone,
                r.rms_pct ? fixed(*r.rms_pct, 4).c_str() : kNone,
                r.facing_away_pct ? fixed(*r.facing_away_pct, 4).c_str() : kNone, fixed(r.seconds, 2).c_str(),
                fixed(r.peak_rss_mib, 1).c_str());
  }
}

// Per ratio: gaussmesh / meshopt_simplify for Hausdorff and RMS over the inputs that have both.
void print_summary(const std::vector<Row>& rows, const std::vector<std::string>& ratios) {
  std::printf("\ngaussmesh against meshopt_simplify at the same face count (ratio of the errors, gaussmesh / "
              "meshopt; over the inputs where both were measured):\n\n");
  std::printf("| ratio | inputs | Hausdorff ratio, worst | Hausdorff ratio, median | RMS ratio, worst | RMS ratio, "
              "median | gaussmesh Hausdorff ≤ meshopt's |\n");
  std::printf("| ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  for (const std::string& ratio : ratios) {
    std::map<std::string, const Row*> ours, theirs;
    std::vector<std::string> order;
    for (const Row& r : rows) {
      if (r.ratio != ratio || !r.hausdorff_pct || !r.rms_pct) continue;
      if (r.tool == kGaussmesh) {
        ours[r.input] = &r;
        order.push_back(r.input);
      } else if (r.tool == kMeshopt) {
        theirs[r.input] = &r;
      }
    }
    std::vector<double> hausdorff, rms;
    size_t not_worse = 0;
    for (const std::string& input : order) {
      const auto it = theirs.find(input);
      if (it == theirs.end()) continue;
      const Row& g = *ours[input];
      const Row& m = *it->second;
      const double inf = std::numeric_limits<double>::infinity();
      hausdorff.push_back(*m.hausdorff_pct > 0 ? *g.hausdorff_pct / *m.hausdorff_pct : inf);
      rms.push_back(*m.rms_pct > 0 ? *g.rms_pct / *m.rms_pct : inf);
      if (*g.hausdorff_pct <= *m.hausdorff_pct) ++not_worse;
    }
    if (hausdorff.empty()) {
      std::printf("| %s | 0 | %s | %s | %s | %s | %s |\n", ratio.c_str(), kNone, kNone, kNone, kNone, kNone);
      continue;
    }
    std::printf("| %s | %zu | %s | %s | %s | %s | %zu of %zu |\n", ratio.c_str(), hausdorff.size(),
                fixed(*std::max_element(hausdorff.begin(), hausdorff.end()), 2).c_str(),
                fixed(median(hausdorff), 2).c_str(), fixed(*std::max_element(rms.begin(), rms.end()), 2).c_str(),
                fixed(median(rms), 2).c_str(), not_worse, hausdorff.size());
  }
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_targets [--ratios R,R,...] [--sizes N,N,...|none] [--large] [--sources cow,torus,...] "
               "[--no-fixtures] [--no-scattered] [--dir D] [--keep] [--no-meshopt] [--compare-max N] [--samples N] "
               "[--gaussmesh PATH] [-- GAUSSMESH SIMPLIFY ARGS...]\n");
  return 1;
}

bool parse_count(const std::string& text, std::uint64_t& value) {
  char* end = nullptr;
  value = std::strtoull(text.c_str(), &end, 10);
  return !text.empty() && *end == '\0' && value > 0;
}

}  // namespace
}  // namespace gaussmesh::bench

int main(int argc, char** argv) {
  using namespace gaussmesh::bench;
  Options options;
  bool large = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") {
      options.extra.assign(argv + i + 1, argv + argc);
      break;
    }
    if (arg == "--large") {
      large = true;
    } else if (arg == "--no-fixtures") {
      options.fixtures = false;
    } else if (arg == "--no-scattered") {
      options.scattered = false;
    } else if (arg == "--keep") {
      options.keep = true;
    } else if (arg == "--no-meshopt") {
      options.meshopt = false;
    } else if (i + 1 < argc && arg == "--ratios") {
      options.ratios = split(argv[++i]);
      for (const std::string& r : options.ratios) {
        char* end = nullptr;
        const double value = std::strtod(r.c_str(), &end);
        if (*end != '\0' || !(value > 0 && value <= 1)) return usage();
      }
      if (options.ratios.empty()) return usage();
    } else if (i + 1 < argc && arg == "--sizes") {
      options.sizes.clear();
      const std::string list = argv[++i];
      if (list == "none") continue;
      for (const std::string& item : split(list)) {
        std::uint64_t n = 0;
        if (!parse_count(item, n)) return usage();
        options.sizes.push_back(n);
      }
    } else if (i + 1 < argc && arg == "--sources") {
      options.sources = split(argv[++i]);
    } else if (i + 1 < argc && arg == "--dir") {
      options.dir = argv[++i];
    } else if (i + 1 < argc && arg == "--compare-max") {
      if (!parse_count(argv[++i], options.compare_max)) return usage();
    } else if (i + 1 < argc && arg == "--samples") {
      options.samples = argv[++i];
    } else if (i + 1 < argc && arg == "--gaussmesh") {
      options.gaussmesh = argv[++i];
    } else {
      return usage();
    }
  }
  if (large) options.sizes.insert(options.sizes.end(), {10'000'000, 100'000'000});

  const fs::path bin_dir = fs::read_symlink("/proc/self/exe").parent_path();
  const std::string generator = (bin_dir / "make_large_mesh").string();
  const std::string scatterer = (bin_dir / "scatter_mesh").string();
  const std::string meshopt = (bin_dir / "meshopt_file").string();
  if (options.meshopt && ::access(meshopt.c_str(), X_OK) != 0) {
    std::fprintf(stderr, "bench_targets: %s not found (meshoptimizer not installed?); use --no-meshopt\n",
                 meshopt.c_str());
    return 1;
  }

  std::error_code ec;
  fs::create_directories(options.dir, ec);
  std::string work_template = (options.dir / "run-XXXXXX").string();
  if (ec || ::mkdtemp(work_template.data()) == nullptr) {
    std::perror(work_template.c_str());
    return 4;
  }
  const fs::path work = work_template;
  Runner runner(options, work, meshopt);
  std::fprintf(stderr, "bench_targets: work dir %s (children's stderr in log.txt)\n", work.c_str());

  std::vector<std::string> notes;
  if (!options.sizes.empty() && !options.scattered) {
    notes.push_back("generated inputs in coherent order only (--no-scattered)");
  }

  // The command line, then the machine, then the table.
  std::string command;
  for (int i = 0; i < argc; ++i) command += (i ? " " : "") + shell_word(argv[i]);
  std::printf("command: `%s`\n\n", command.c_str());
  std::printf("machine: %ld cores, MemTotal %.0f MB, MemAvailable %.0f MB, loadavg at start: %s\n\n",
              ::sysconf(_SC_NPROCESSORS_ONLN), meminfo_mb("MemTotal:"), meminfo_mb("MemAvailable:"),
              first_line("/proc/loadavg").c_str());
  std::fflush(stdout);

  if (options.fixtures) {
    std::vector<fs::path> fixtures;
    for (const auto& entry : fs::directory_iterator(gaussmesh::testing::fixture("real"), ec)) {
      const std::string ext = entry.path().extension().string();
      if (entry.is_regular_file() && (ext == ".off" || ext == ".ply")) fixtures.push_back(entry.path());
    }
    std::sort(fixtures.begin(), fixtures.end());
    for (const fs::path& path : fixtures) {
      Input input{path.filename().string(), path, header_faces(path)};
      runner.run(input);
    }
  }

  const double max_ratio = std::stod(*std::max_element(options.ratios.begin(), options.ratios.end(),
                                                       [](const std::string& a, const std::string& b) {
                                                         return std::stod(a) < std::stod(b);
                                                       }));
  for (std::uint64_t size : options.sizes) {
    for (const std::string& source : options.sources) {
      const std::string name = fs::path(source).stem().string();
      Input coherent{"generated " + name + " " + size_label(size), work / (name + "-" + std::to_string(size) + ".ply"),
                     size};
      Input scattered{coherent.label + ", scattered", work / (name + "-" + std::to_string(size) + "-scattered.ply"),
                      size};
      auto skip_all = [&](const Input& input, const std::string& why) {
        for (const std::string& ratio : options.ratios) {
          Row row{input.label, input.faces, ratio, "(all)"};
          row.note = why;
          runner.add_note_row(row);
        }
      };
      // Both copies while the scattered one is written, and the largest output (one at a time).
      const double need_gb =
          double(size) * kPlyBytesPerTriangle * 1.1 * ((options.scattered ? 2 : 1) + max_ratio) / 1e9 + 0.05;
      const double free_gb = free_disk_gb(work);
      std::fprintf(stderr, "bench_targets: %s needs ~%.2f GB in %s; %.1f GB free\n", coherent.label.c_str(), need_gb,
                   work.c_str(), free_gb);
      if (free_gb < need_gb) {
        const std::string why =
            "skipped: needs " + fixed(need_gb, 1) + " GB of disk, " + fixed(free_gb, 1) + " GB free";
        skip_all(coherent, why);
        if (options.scattered) skip_all(scattered, why);
        continue;
      }
      std::uintmax_t log_before = runner.log_size();
      const ChildRun made = run_child({generator, "--triangles", std::to_string(size), "--source", source, "--out",
                                       coherent.path.string()},
                                      work / "make.out", runner.log());
      if (made.exit_code != 0) {
        const std::string why = "make_large_mesh " + runner.failure(made.exit_code, log_before);
        skip_all(coherent, why);
        if (options.scattered) skip_all(scattered, why);
        runner.count_failure();
        continue;
      }
      coherent.faces = scattered.faces = header_faces(coherent.path);  // the generator rounds to its grid
      std::fprintf(stderr, "bench_targets: made %s: %llu triangles, %.0f MB in %.1f s\n", coherent.label.c_str(),
                   (unsigned long long)coherent.faces, double(fs::file_size(coherent.path, ec)) / 1e6, made.seconds);
      runner.run(coherent);
      if (options.scattered) {
        // scatter_mesh holds the whole mesh: ~40 bytes a triangle.
        const double scatter_mb = double(coherent.faces) * kScatterBytesPerTriangle / 1e6;
        const double available = meminfo_mb("MemAvailable:");
        if (scatter_mb > kMemoryShare * available) {
          skip_all(scattered, "skipped: scatter_mesh needs ~" + fixed(scatter_mb / 1000, 1) + " GB, " +
                                  fixed(available / 1000, 1) + " GB available");
        } else {
          log_before = runner.log_size();
          const ChildRun copied =
              run_child({scatterer, coherent.path.string(), scattered.path.string()}, work / "make.out", runner.log());
          if (copied.exit_code != 0) {
            skip_all(scattered, "scatter_mesh " + runner.failure(copied.exit_code, log_before));
            runner.count_failure();
          } else {
            std::fprintf(stderr, "bench_targets: made %s in %.1f s, peak RSS %.0f MB\n", scattered.label.c_str(),
                         copied.seconds, copied.peak_rss_mb);
            if (!options.keep) fs::remove(coherent.path, ec);
            runner.run(scattered);
          }
        }
      }
      if (!options.keep) {
        fs::remove(coherent.path, ec);
        fs::remove(scattered.path, ec);
      }
    }
  }

  print_table(runner.rows());
  for (const std::string& note : notes) std::printf("\n%s\n", note.c_str());
  if (!options.meshopt) std::printf("\nmeshopt rows: off (--no-meshopt)\n");
  if (options.meshopt) print_summary(runner.rows(), options.ratios);
  std::printf("\nloadavg at end: %s\n", first_line("/proc/loadavg").c_str());

  // Clean up: the run directory, except what --keep keeps and the log of a failure.
  fs::remove(work / "make.out", ec);
  for (const char* scratch : {"simplify.out", "meshopt.out", "compare.out"}) fs::remove(work / scratch, ec);
  const bool keep_log = runner.failures() > 0;
  if (!keep_log) fs::remove(runner.log(), ec);
  if (options.keep || keep_log) {
    std::fprintf(stderr, "bench_targets: kept %s%s\n", work.c_str(),
                 keep_log ? " (a child failed: see log.txt)" : "");
  } else {
    fs::remove_all(work, ec);
  }
  return 0;
}
