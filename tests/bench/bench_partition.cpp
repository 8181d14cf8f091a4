// Benchmark of the ingest and partition passes (stream/partition/chunk_partition.h): generates refined-cow PLY inputs with
// make_large_mesh, optionally a badly ordered copy (vertex ids and face order shuffled), runs
// partition_mesh on each in a child process (fork + exec of this program, so the child's peak
// RSS — wait4's ru_maxrss — is its own), and prints a markdown table.
//
//   bench_partition [--sizes N,N,...] [--memory BYTES] [--rings K] [--threads T] [--level L]
//                   [--dir D] [--shuffle-max N] [--keep]
//   bench_partition --child INPUT MEMORY RINGS THREADS LEVEL TMPDIR [read-back]
//       (one run; key=value line; read-back: then loads every chunk and builds its adjacency on one
//       thread, and prints the CPU seconds of each — what the sample and loops passes pay per chunk)
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <tbb/global_control.h>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "format/temp_registry.h"
#include "stream/partition/chunk_partition.h"
#include "stream/core/mesh.h"
#include "stream/core/mesh_adjacency.h"
#include "tests/support/scattered_copy.h"
#include "tests/support/child_process.h"
#include "tests/support/machine.h"

namespace gaussmesh::bench {
namespace {

namespace fs = std::filesystem;

using testing::ChildRun;
using testing::first_line;
using testing::free_disk_gb;
using testing::parse_pairs;
using testing::run_child;

// The child: one partition, figures on stdout.
int child_main(int argc, char** argv) {
  if (argc != 8 && argc != 9) return 1;
  format::install_signal_cleanup();  // an interrupted run leaves no temp dir behind
  stream::PartitionOptions options;
  options.memory_bytes = std::strtoull(argv[3], nullptr, 10);
  options.rings = static_cast<std::uint32_t>(std::strtoul(argv[4], nullptr, 10));
  options.threads = static_cast<std::uint32_t>(std::strtoul(argv[5], nullptr, 10));
  options.compression_level = std::atoi(argv[6]);
  options.tmp_dir = argv[7];
  auto partition = stream::partition_mesh(argv[2], {}, options);
  if (!partition) {
    std::fprintf(stderr, "%s\n", partition.status().to_string().c_str());
    return static_cast<int>(partition.status().code());
  }
  std::uint64_t records = 0, largest = 0, chunk_bytes = 0;
  for (const auto& c : partition->chunks) {
    records += c.faces;
    largest = std::max(largest, c.faces);
    chunk_bytes += fs::file_size(c.path);
  }
  std::printf("plan=%.3f rings=%.3f chunks_step=%.3f ", partition->steps.plan, partition->steps.rings, partition->steps.chunks);
  std::printf("ingest=%.3f partition=%.3f vertices=%llu faces=%llu chunks=%zu records=%llu largest=%llu spilled=%llu misses=%llu cache_bytes=%llu chunk_bytes=%llu\n",
              partition->seconds_ingest, partition->seconds_partition, (unsigned long long)partition->vertices,
              (unsigned long long)partition->faces, partition->chunks.size(), (unsigned long long)records,
              (unsigned long long)largest, (unsigned long long)partition->bytes_spilled,
              (unsigned long long)partition->cache_misses, (unsigned long long)partition->cache_bytes,
              (unsigned long long)chunk_bytes);
  if (argc == 9 && std::string(argv[8]) == "read-back") {
    auto cpu = [] {
      timespec t{};
      ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
      return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
    };
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);  // the adjacency's parallel_for
    double load = 0, adjacency = 0;
    stream::MeshAdjacency adj;
    for (const auto& c : partition->chunks) {
      const double t0 = cpu();
      auto chunk = stream::load_chunk(c);
      const double t1 = cpu();
      if (!chunk) {
        std::fprintf(stderr, "%s\n", chunk.status().to_string().c_str());
        return static_cast<int>(chunk.status().code());
      }
      if (!stream::build_mesh_adjacency(chunk->view(), adj).is_ok()) return 1;
      load += t1 - t0;
      adjacency += cpu() - t1;
    }
    std::printf("load_cpu=%.3f adjacency_cpu=%.3f\n", load, adjacency);
  }
  return 0;
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_partition [--sizes N,N,...] [--memory BYTES] [--rings K] [--threads T] [--level L] "
               "[--dir D] [--shuffle-max N] [--keep]\n");
  return 1;
}

}  // namespace
}  // namespace gaussmesh::bench

int main(int argc, char** argv) {
  using namespace gaussmesh::bench;
  if (argc > 1 && std::string(argv[1]) == "--child") return child_main(argc, argv);
  std::vector<std::uint64_t> sizes = {1'000'000, 10'000'000};
  std::uint64_t memory = 64ull << 20, shuffle_max = 10'000'000;
  std::string rings = "3", threads = "1", level = "1";
  fs::path dir = "/var/tmp";
  bool keep = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--keep") {
      keep = true;
    } else if (i + 1 < argc && arg == "--sizes") {
      sizes.clear();
      std::stringstream list(argv[++i]);
      std::string item;
      while (std::getline(list, item, ',')) sizes.push_back(std::strtoull(item.c_str(), nullptr, 10));
    } else if (i + 1 < argc && arg == "--memory") {
      memory = std::strtoull(argv[++i], nullptr, 10);
    } else if (i + 1 < argc && arg == "--rings") {
      rings = argv[++i];
    } else if (i + 1 < argc && arg == "--threads") {
      threads = argv[++i];
    } else if (i + 1 < argc && arg == "--level") {
      level = argv[++i];
    } else if (i + 1 < argc && arg == "--dir") {
      dir = argv[++i];
    } else if (i + 1 < argc && arg == "--shuffle-max") {
      shuffle_max = std::strtoull(argv[++i], nullptr, 10);
    } else {
      return usage();
    }
  }
  const fs::path self = fs::read_symlink("/proc/self/exe");
  const std::string generator = (self.parent_path() / "make_large_mesh").string();
  std::string work_template = (dir / "bench_partition-XXXXXX").string();
  if (::mkdtemp(work_template.data()) == nullptr) {
    std::perror(work_template.c_str());
    return 4;
  }
  const fs::path work = work_template;
  const fs::path log = work / "log.txt";
  std::fprintf(stderr, "bench_partition: work dir %s (child stderr in log.txt)\n", work.c_str());
  std::printf("machine: %ld cores, loadavg at start: %s\n", ::sysconf(_SC_NPROCESSORS_ONLN), first_line("/proc/loadavg").c_str());
  std::printf("CPU s = user + system seconds of the child (robust to other load; wall seconds are not)\n");
  std::printf("partition_mesh: --memory %llu (%.0f MiB), rings %s, threads %s, zstd level %s, temp in %s\n\n",
              (unsigned long long)memory, double(memory) / (1 << 20), rings.c_str(), threads.c_str(), level.c_str(),
              work.c_str());
  std::printf("| input | order | triangles | ingest s | partition s | M triangles/s | CPU s | chunks | records / triangle | "
              "largest chunk | spilled GB | chunk files GB | cache misses | cache MiB | peak RSS MB |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
  std::fflush(stdout);
  for (std::uint64_t size : sizes) {
    const double need_gb = double(size) * (19 + 19 + 12 + 60) * 1.2 / 1e9;  // input, shuffled copy, spills, chunks
    const double free_gb = free_disk_gb(work);
    if (free_gb < need_gb) {
      std::printf("| cow %llu | | skipped: needs ~%.0f GB of disk, %.0f GB free |\n", (unsigned long long)size, need_gb, free_gb);
      continue;
    }
    const fs::path input = work / ("in-" + std::to_string(size) + ".ply");
    ChildRun made = run_child({generator, "--triangles", std::to_string(size), "--out", input.string()}, work / "make.out", log);
    if (made.exit_code != 0) {
      std::printf("| cow %llu | | make_large_mesh failed (exit %d) |\n", (unsigned long long)size, made.exit_code);
      continue;
    }
    std::vector<std::pair<std::string, fs::path>> inputs = {{"ordered", input}};
    if (size <= shuffle_max) {
      const fs::path shuffled = work / ("shuffled-" + std::to_string(size) + ".ply");
      if (gaussmesh::testing::write_scattered_copy(input.string(), shuffled.string(), 7)) inputs.push_back({"shuffled", shuffled});
    }
    for (const auto& [order, path] : inputs) {
      const fs::path tmp = work / "tmp";
      fs::create_directories(tmp);
      ChildRun r = run_child({self.string(), "--child", path.string(), std::to_string(memory), rings, threads, level,
                              tmp.string()},
                             work / "child.out", log);
      auto f = parse_pairs(r.out);
      if (r.exit_code != 0 || f.count("faces") == 0) {
        std::printf("| cow %llu | %s | failed (exit %d, see %s) |\n", (unsigned long long)size, order.c_str(), r.exit_code,
                    log.c_str());
        continue;
      }
      const double faces = std::stod(f["faces"]), ingest = std::stod(f["ingest"]), part = std::stod(f["partition"]);
      std::printf("| cow %llu | %s | %.0f | %.2f | %.2f | %.2f | %.2f | %s | %.2f | %s | %.2f | %.2f | %s | %.1f | %.0f |\n",
                  (unsigned long long)size, order.c_str(), faces, ingest, part, faces / (ingest + part) / 1e6,
                  r.cpu_seconds, f["chunks"].c_str(), std::stod(f["records"]) / faces, f["largest"].c_str(),
                  std::stod(f["spilled"]) / 1e9, std::stod(f["chunk_bytes"]) / 1e9, f["misses"].c_str(),
                  std::stod(f["cache_bytes"]) / (1 << 20), r.peak_rss_mb);
      std::fflush(stdout);
    }
    if (!keep)
      for (const auto& [order, path] : inputs) fs::remove(path);
  }
  std::printf("\nloadavg at end: %s\n", first_line("/proc/loadavg").c_str());
  if (!keep) fs::remove_all(work);
  return 0;
}
