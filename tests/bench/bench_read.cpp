// Benchmark of the streaming PLY reader: writes a binary little-endian PLY of N triangles (a
// wavy height-field grid, float xyz + "list uchar int" faces), then reads it with read_ply into
// a sink that only counts and checksums, in a fresh process (fork + exec of this program with
// --read) so that the peak RSS printed is the read's alone. Prints a table; not a timed test.
//
//   bench_read [--triangles N] [--dir D] [--repeat R]   generate, read, remove
//   bench_read --read FILE [--repeat R]                 read an existing PLY only
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "format/byte_source.h"
#include "format/mesh_reader.h"
#include "format/output_file.h"
#include "stream/core/process_memory.h"

namespace gaussmesh::bench {
namespace {

using format::Status;

class ChecksumSink final : public format::MeshSink {
 public:
  Status on_vertices(std::span<const format::Vec3f> batch) override {
    vertices += batch.size();
    for (const format::Vec3f& p : batch) coordinate_sum += double(p.x) + double(p.y) + double(p.z);
    return {};
  }
  Status on_triangles(std::span<const format::Triangle> batch) override {
    triangles += batch.size();
    for (const format::Triangle& t : batch) index_hash = index_hash * 31 + (t.v[0] ^ (t.v[1] << 7) ^ (t.v[2] << 13));
    return {};
  }
  uint64_t vertices = 0, triangles = 0, index_hash = 0;
  double coordinate_sum = 0;
};

// Writes a (w+1) x (h+1) grid with 2wh triangles, streaming: memory does not grow with N.
Status generate(const std::string& path, uint64_t wanted_triangles, uint64_t& triangles_out) {
  const uint64_t w = std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(std::sqrt(wanted_triangles / 2.0))));
  const uint64_t h = std::max<uint64_t>(1, (wanted_triangles + 2 * w - 1) / (2 * w));
  const uint64_t vertices = (w + 1) * (h + 1);
  triangles_out = 2 * w * h;
  auto out = format::OutputFile::create(path, true);
  if (!out) return out.status();
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment bench_read grid\nelement vertex " +
                       std::to_string(vertices) + "\nproperty float x\nproperty float y\nproperty float z\n" +
                       "element face " + std::to_string(triangles_out) +
                       "\nproperty list uchar int vertex_indices\nend_header\n";
  GM_RETURN_IF_ERROR((*out)->write(header));
  std::vector<char> row;
  for (uint64_t j = 0; j <= h; ++j) {
    row.clear();
    for (uint64_t i = 0; i <= w; ++i) {
      float p[3] = {float(i) / float(w), float(j) / float(h),
                    0.05f * std::sin(float(i) * 0.01f) * std::cos(float(j) * 0.013f)};
      row.insert(row.end(), reinterpret_cast<char*>(p), reinterpret_cast<char*>(p) + 12);
    }
    GM_RETURN_IF_ERROR((*out)->write(row.data(), row.size()));
  }
  for (uint64_t j = 0; j < h; ++j) {
    row.clear();
    for (uint64_t i = 0; i < w; ++i) {
      int32_t a = int32_t(j * (w + 1) + i), b = a + 1, c = a + int32_t(w + 1), d = c + 1;
      int32_t faces[2][3] = {{a, b, d}, {a, d, c}};
      for (auto& f : faces) {
        row.push_back(3);
        row.insert(row.end(), reinterpret_cast<char*>(f), reinterpret_cast<char*>(f) + 12);
      }
    }
    GM_RETURN_IF_ERROR((*out)->write(row.data(), row.size()));
  }
  return (*out)->commit();
}

int read_mode(const std::string& path, int repeat) {
  double best = 1e30;
  uint64_t size = std::filesystem::file_size(path);
  ChecksumSink last;
  std::printf("%-6s %12s %12s %10s %9s %10s %10s\n", "run", "vertices", "triangles", "file MB", "seconds", "MB/s",
              "Mtri/s");
  for (int r = 0; r < repeat; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    auto source = format::ByteSource::open(path);
    if (!source) {
      std::fprintf(stderr, "%s\n", source.status().to_string().c_str());
      return 2;
    }
    ChecksumSink sink;
    Status status = format::read_ply(**source, format::ReadOptions{}, sink);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!status) {
      std::fprintf(stderr, "%s\n", status.to_string().c_str());
      return 2;
    }
    double mb = double(size) / 1e6;
    std::printf("%-6d %12llu %12llu %10.1f %9.3f %10.0f %10.1f\n", r + 1, (unsigned long long)sink.vertices,
                (unsigned long long)sink.triangles, mb, seconds, mb / seconds, double(sink.triangles) / seconds / 1e6);
    best = std::min(best, seconds);
    last = sink;
  }
  std::printf("best %.3f s = %.0f MB/s, %.1f M triangles/s; peak RSS of the read process %.1f MB "
              "(checksum %.6g / %llx)\n",
              best, double(size) / 1e6 / best, double(last.triangles) / best / 1e6, double(stream::peak_rss()) / 1e6,
              last.coordinate_sum, (unsigned long long)last.index_hash);
  return 0;
}

int usage() {
  std::fprintf(stderr, "usage: bench_read [--triangles N] [--dir D] [--repeat R] | --read FILE [--repeat R]\n");
  return 1;
}

}  // namespace
}  // namespace gaussmesh::bench

int main(int argc, char** argv) {
  using namespace gaussmesh::bench;
  uint64_t triangles = 20'000'000;
  std::string dir = std::filesystem::temp_directory_path().string();
  std::string read_path;
  int repeat = 3;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (i + 1 >= argc) return usage();
    std::string value = argv[++i];
    if (arg == "--triangles") {
      triangles = std::strtoull(value.c_str(), nullptr, 10);
    } else if (arg == "--dir") {
      dir = value;
    } else if (arg == "--read") {
      read_path = value;
    } else if (arg == "--repeat") {
      repeat = std::max(1, std::atoi(value.c_str()));
    } else {
      return usage();
    }
  }
  if (!read_path.empty()) return read_mode(read_path, repeat);

  std::string path = dir + "/bench_read-" + std::to_string(::getpid()) + ".ply";
  uint64_t made = 0;
  auto t0 = std::chrono::steady_clock::now();
  Status status = generate(path, triangles, made);
  if (!status) {
    std::fprintf(stderr, "%s\n", status.to_string().c_str());
    return 4;
  }
  std::fprintf(stderr, "generated %s: %llu triangles in %.1f s\n", path.c_str(), (unsigned long long)made,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  std::fflush(stdout);
  // The read runs in a fresh process so that VmHWM is the read's alone.
  pid_t child = ::fork();
  if (child == 0) {
    std::string repeat_text = std::to_string(repeat);
    ::execl("/proc/self/exe", argv[0], "--read", path.c_str(), "--repeat", repeat_text.c_str(), (char*)nullptr);
    std::perror("exec");
    std::_Exit(127);
  }
  int wstatus = 0;
  ::waitpid(child, &wstatus, 0);
  std::filesystem::remove(path);
  return WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 3;
}
