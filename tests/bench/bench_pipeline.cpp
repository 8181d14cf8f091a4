// Benchmark of the whole simplification job at scale (the out-of-core issue's table): makes
// large binary PLY inputs with make_large_mesh, runs `gaussmesh simplify` and meshoptimizer's
// meshopt_simplify / meshopt_simplifySloppy as whole processes (reading and writing included,
// meshopt_file), measures each child's wall seconds and peak RSS with wait4's rusage (no
// dependency on /usr/bin/time), then `gaussmesh compare` for Hausdorff and RMS, and prints a
// markdown table. Not a timed test.
//
//   bench_pipeline [--sizes 1000000,10000000] [--large] [--source cow|sphere|torus|FILE]
//                  [--noise X] [--seed S] [--dir D] [--samples N] [--no-meshopt] [--keep]
//                  [--compare-max N] [--gaussmesh PATH] [-- EXTRA GAUSSMESH SIMPLIFY ARGS...]
//
// --large adds 100M triangles (about 1.9 GB of PLY). Before each size the free disk space in D
// is checked, and before each run the peak RSS is extrapolated (linearly in input triangles) from
// the same tool's largest earlier run: a run predicted to need more than 85 % of MemAvailable is
// skipped and says so. Arguments after `--` go to `gaussmesh simplify` unchanged (e.g.
// `-- --memory 2G` once the out-of-core pipeline has it). gaussmesh's .drc is decoded with
// draco_decoder (if on PATH) before comparing, so its error includes Draco's quantization.
// compare's cost grows with the input whatever --samples says (every input vertex and edge
// midpoint is measured: ~45 s at 10M triangles on 2 busy cores), so inputs above --compare-max
// triangles (default 20M) get no error figures. --gaussmesh runs another build of the tool (default: the one built beside this program).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
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

std::optional<nlohmann::json> read_json(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  try {
    return nlohmann::json::parse(in);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

bool on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (!dir.empty() && ::access((fs::path(dir) / program).c_str(), X_OK) == 0) return true;
  }
  return false;
}

struct Row {
  std::string tool;
  std::uint64_t input_faces = 0;
  std::string note;  // set when the run was skipped or failed
  double seconds = 0, peak_rss_mb = 0;
  std::uint64_t output_faces = 0;
  std::optional<double> hausdorff_pct, rms_pct;
  double compare_seconds = 0;
};

std::string fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

void print_table(const std::vector<Row>& rows) {
  std::printf("\n| tool | input triangles | seconds | M triangles/s | peak RSS MB | output faces | Hausdorff %% | RMS %% |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
  for (const Row& r : rows) {
    if (!r.note.empty()) {
      std::printf("| %s | %llu | %s | | | | | |\n", r.tool.c_str(), (unsigned long long)r.input_faces, r.note.c_str());
      continue;
    }
    std::printf("| %s | %llu | %s | %s | %s | %llu | %s | %s |\n", r.tool.c_str(), (unsigned long long)r.input_faces,
                fixed(r.seconds, 2).c_str(), fixed(double(r.input_faces) / r.seconds / 1e6, 2).c_str(),
                fixed(r.peak_rss_mb, 0).c_str(), (unsigned long long)r.output_faces,
                r.hausdorff_pct ? fixed(*r.hausdorff_pct, 3).c_str() : "n/a",
                r.rms_pct ? fixed(*r.rms_pct, 4).c_str() : "n/a");
  }
  std::fflush(stdout);
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_pipeline [--sizes N,N,...] [--large] [--source cow|sphere|torus|FILE] [--noise X] "
               "[--seed S] [--dir D] [--samples N] [--no-meshopt] [--keep] [--compare-max N] [--gaussmesh PATH] "
               "[-- GAUSSMESH ARGS...]\n");
  return 1;
}

}  // namespace
}  // namespace gaussmesh::bench

int main(int argc, char** argv) {
  using namespace gaussmesh::bench;
  std::vector<std::uint64_t> sizes = {1'000'000, 10'000'000};
  std::string source = "cow", noise, seed = "1", samples = "100000";
  fs::path dir = fs::temp_directory_path();
  bool large = false, with_meshopt = true, keep = false;
  std::vector<std::string> extra;
  std::string gaussmesh = gaussmesh::testing::gaussmesh_binary();
  std::uint64_t compare_max = 20'000'000;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--") {
      extra.assign(argv + i + 1, argv + argc);
      break;
    }
    if (arg == "--large") {
      large = true;
    } else if (arg == "--no-meshopt") {
      with_meshopt = false;
    } else if (arg == "--keep") {
      keep = true;
    } else if (i + 1 < argc && arg == "--sizes") {
      sizes.clear();
      std::istringstream list(argv[++i]);
      std::string item;
      while (std::getline(list, item, ',')) sizes.push_back(std::strtoull(item.c_str(), nullptr, 10));
    } else if (i + 1 < argc && arg == "--source") {
      source = argv[++i];
    } else if (i + 1 < argc && arg == "--noise") {
      noise = argv[++i];
    } else if (i + 1 < argc && arg == "--seed") {
      seed = argv[++i];
    } else if (i + 1 < argc && arg == "--dir") {
      dir = argv[++i];
    } else if (i + 1 < argc && arg == "--compare-max") {
      compare_max = std::strtoull(argv[++i], nullptr, 10);
    } else if (i + 1 < argc && arg == "--gaussmesh") {
      gaussmesh = argv[++i];
    } else if (i + 1 < argc && arg == "--samples") {
      samples = argv[++i];
    } else {
      return usage();
    }
  }
  if (large) sizes.push_back(100'000'000);

  const fs::path bin_dir = fs::read_symlink("/proc/self/exe").parent_path();
  const std::string generator = (bin_dir / "make_large_mesh").string();
  const std::string meshopt = (bin_dir / "meshopt_file").string();
  const bool have_decoder = on_path("draco_decoder");

  std::string work_template = (dir / "bench_pipeline-XXXXXX").string();
  if (::mkdtemp(work_template.data()) == nullptr) {
    std::perror(work_template.c_str());
    return 4;
  }
  const fs::path work = work_template;
  const fs::path log = work / "log.txt";
  std::fprintf(stderr, "bench_pipeline: work dir %s (child stderr in log.txt)\n", work.c_str());

  std::printf("machine: %ld cores, MemTotal %.0f MB, MemAvailable %.0f MB, loadavg at start: %s\n",
              ::sysconf(_SC_NPROCESSORS_ONLN), meminfo_mb("MemTotal:"), meminfo_mb("MemAvailable:"),
              first_line("/proc/loadavg").c_str());
  std::printf("gaussmesh: %s simplify IN -o OUT.drc --report R.json", gaussmesh.c_str());
  for (const auto& a : extra) std::printf(" %s", a.c_str());
  std::printf("\ninput: make_large_mesh --source %s --seed %s%s%s; compare --samples %s up to %llu triangles%s\n",
              source.c_str(), seed.c_str(), noise.empty() ? "" : " --noise ", noise.c_str(), samples.c_str(),
              (unsigned long long)compare_max,
              have_decoder ? "; gaussmesh output decoded by draco_decoder before compare"
                           : "; draco_decoder not found: gaussmesh rows have no error figures");

  std::vector<Row> rows;
  std::map<std::string, std::pair<std::uint64_t, double>> largest;  // tool -> (faces, peak RSS MB)
  std::vector<std::string> generator_lines;
  for (std::uint64_t size : sizes) {
    // Disk: ~19 bytes per triangle of PLY (13 per face, ~6 per vertex) plus small outputs.
    const double need_gb = double(size) * 19 * 1.1 / 1e9 + 0.05;
    const double free_gb = free_disk_gb(work);
    std::fprintf(stderr, "bench_pipeline: %llu triangles need ~%.1f GB in %s; %.1f GB free\n",
                 (unsigned long long)size, need_gb, work.c_str(), free_gb);
    if (free_gb < need_gb) {
      rows.push_back({"(all)", size, "skipped: needs " + fixed(need_gb, 1) + " GB of disk, " + fixed(free_gb, 1) + " GB free"});
      continue;
    }
    const fs::path input = work / ("in-" + std::to_string(size) + ".ply");
    std::vector<std::string> make = {generator, "--triangles", std::to_string(size), "--source", source,
                                     "--seed", seed, "--out", input.string()};
    if (!noise.empty()) make.insert(make.end(), {"--noise", noise});
    ChildRun made = run_child(make, work / "make.out", log);
    if (made.exit_code != 0) {
      rows.push_back({"(all)", size, "make_large_mesh failed (exit " + std::to_string(made.exit_code) + ", see log)"});
      continue;
    }
    // The true triangle count: the generator rounds to its grid.
    std::uint64_t faces = size;
    {
      std::ifstream in(input, std::ios::binary);
      std::string line;
      while (std::getline(in, line) && line != "end_header") {
        if (line.rfind("element face ", 0) == 0) faces = std::strtoull(line.c_str() + 13, nullptr, 10);
      }
    }
    generator_lines.push_back("| " + std::to_string(faces) + " | " + fixed(double(fs::file_size(input)) / 1e6, 0) +
                              " | " + fixed(made.seconds, 1) + " | " + fixed(made.peak_rss_mb, 1) + " |");

    // Skips a run whose extrapolated peak RSS would not fit; returns the reason or "".
    auto memory_guard = [&](const std::string& tool) -> std::string {
      auto it = largest.find(tool);
      if (it == largest.end()) return "";
      const double predicted = it->second.second * double(faces) / double(it->second.first);
      const double available = meminfo_mb("MemAvailable:");
      if (predicted <= 0.85 * available) return "";
      return "skipped: ~" + fixed(predicted / 1000, 1) + " GB predicted peak RSS, " + fixed(available / 1000, 1) +
             " GB available";
    };
    auto compare = [&](Row& row, const fs::path& output) {
      if (faces > compare_max) return;
      const fs::path report = work / "compare.json";
      ChildRun c = run_child({gaussmesh, "compare", input.string(), output.string(), "--samples", samples, "--report",
                              report.string(), "-q"},
                             work / "compare.out", log);
      row.compare_seconds = c.seconds;
      auto json = read_json(report);
      if (c.exit_code == 0 && json) {
        row.hausdorff_pct = json->value("hausdorff_pct", -1.0);
        row.rms_pct = json->value("rms_pct", -1.0);
      }
      fs::remove(report);
    };

    // gaussmesh simplify.
    std::uint64_t target = 0;
    {
      Row row{"gaussmesh simplify", faces};
      row.note = memory_guard(row.tool);
      if (row.note.empty()) {
        const fs::path out = work / "gaussmesh.drc", report = work / "simplify.json";
        std::vector<std::string> cmd = {gaussmesh, "simplify", input.string(), "-o", out.string(), "--report",
                                        report.string(), "-q"};
        cmd.insert(cmd.end(), extra.begin(), extra.end());
        ChildRun r = run_child(cmd, work / "simplify.out", log);
        auto json = read_json(report);
        if (r.exit_code != 0 || !json) {
          row.note = "failed (exit " + std::to_string(r.exit_code) + ", see log)";
        } else {
          row.seconds = r.seconds;
          row.peak_rss_mb = r.peak_rss_mb;
          row.output_faces = json->value("output_faces", std::uint64_t{0});
          target = row.output_faces;
          largest[row.tool] = {faces, r.peak_rss_mb};
          if (have_decoder) {
            const fs::path decoded = work / "gaussmesh-decoded.ply";
            ChildRun d = run_child({"draco_decoder", "-i", out.string(), "-o", decoded.string()}, work / "decode.out", log);
            if (d.exit_code == 0) compare(row, decoded);
            fs::remove(decoded);
          }
        }
        fs::remove(out);
        fs::remove(report);
      }
      rows.push_back(row);
    }

    // meshoptimizer, asked for gaussmesh's output face count (or 1 % of the input without it).
    if (with_meshopt) {
      if (target == 0) target = std::max<std::uint64_t>(1, faces / 100);
      for (bool sloppy : {false, true}) {
        Row row{sloppy ? "meshopt_simplifySloppy" : "meshopt_simplify", faces};
        row.note = memory_guard(row.tool);
        if (row.note.empty()) {
          const fs::path out = work / "meshopt.ply";
          std::vector<std::string> cmd = {meshopt, input.string(), "--target-faces", std::to_string(target), "-o",
                                          out.string()};
          if (sloppy) cmd.push_back("--sloppy");
          ChildRun r = run_child(cmd, work / "meshopt.out", log);
          auto pairs = parse_pairs(r.out);
          if (r.exit_code != 0 || !pairs.count("output_faces")) {
            row.note = "failed (exit " + std::to_string(r.exit_code) + ", see log)";
          } else {
            row.seconds = r.seconds;
            row.peak_rss_mb = r.peak_rss_mb;
            row.output_faces = std::strtoull(pairs["output_faces"].c_str(), nullptr, 10);
            largest[row.tool] = {faces, r.peak_rss_mb};
            std::fprintf(stderr, "bench_pipeline: %s %llu: %s", row.tool.c_str(), (unsigned long long)faces,
                         r.out.c_str());
            compare(row, out);
          }
          fs::remove(out);
        }
        rows.push_back(row);
      }
    }
    fs::remove(input);
    for (const Row& r : rows) {
      if (r.input_faces == faces && r.note.empty()) {
        std::fprintf(stderr, "bench_pipeline: %s %llu: %.2f s, %.0f MB, compare %.1f s\n", r.tool.c_str(),
                     (unsigned long long)faces, r.seconds, r.peak_rss_mb, r.compare_seconds);
      }
    }
  }

  print_table(rows);
  std::printf("\nmake_large_mesh (the inputs):\n\n| triangles | PLY MB | seconds | peak RSS MB |\n| --- | --- | --- | --- |\n");
  for (const auto& line : generator_lines) std::printf("%s\n", line.c_str());
  std::printf("\ncompare seconds (not in the table):");
  for (const Row& r : rows) {
    if (r.hausdorff_pct) std::printf(" %s@%llu %.1f;", r.tool.c_str(), (unsigned long long)r.input_faces, r.compare_seconds);
  }
  std::printf("\nloadavg at end: %s\n", first_line("/proc/loadavg").c_str());
  if (keep) {
    std::fprintf(stderr, "bench_pipeline: kept %s\n", work.c_str());
  } else {
    std::error_code ec;
    fs::remove_all(work, ec);
  }
  return 0;
}
