// Benchmark of Draco input's memory: reads each .drc given with read_mesh_file into a sink that
// only counts, each in a fresh process (this program exec'ed with --one), and prints the file's
// header counts, its size, the process's peak RSS before and after the read, and the difference
// per face: the basis of draco_reader.cpp's decode estimate (docs/formats.md, "Draco input").
// Prints a table; not a timed test. --encode writes the inputs: a mesh file as Draco, with the
// method chosen, its points kept as they are (draco_encoder merges equal points, so a soup would
// not stay one), positions quantized to 14 bits:
//   make_large_mesh --triangles 1000000 --source cow --out cow.ply
//   bench_draco_decode --encode cow.ply cow-eb.drc edgebreaker|sequential [SPEED 0..10, default 5]
//
//   bench_draco_decode FILE.drc...
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include <draco/compression/encode.h>
#include <draco/core/encoder_buffer.h>
#include <draco/mesh/mesh.h>

#include "format/draco_header.h"
#include "format/mesh_reader.h"
#include "stream/core/process_memory.h"

namespace gaussmesh::bench {
namespace {

struct Count final : format::MeshSink {
  std::uint64_t vertices = 0, triangles = 0;
  format::Status on_vertices(std::span<const Vec3f> b) override {
    vertices += b.size();
    return {};
  }
  format::Status on_triangles(std::span<const Triangle> b) override {
    triangles += b.size();
    return {};
  }
};

struct Hold final : format::MeshSink {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  format::Status on_vertices(std::span<const Vec3f> b) override {
    positions.insert(positions.end(), b.begin(), b.end());
    return {};
  }
  format::Status on_triangles(std::span<const Triangle> b) override {
    triangles.insert(triangles.end(), b.begin(), b.end());
    return {};
  }
};

int encode(const char* in, const char* out, const std::string& method, int speed) {
  Hold mesh;
  format::ReadOptions read;
  read.weld_stl = false;
  format::Status s = format::read_mesh_file(in, read, mesh);
  if (!s.is_ok()) {
    std::fprintf(stderr, "%s\n", s.to_string().c_str());
    return 2;
  }
  draco::Mesh d;
  const auto points = static_cast<std::uint32_t>(mesh.positions.size());
  d.set_num_points(points);
  draco::GeometryAttribute position;
  position.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, sizeof(Vec3f), 0);
  const int id = d.AddAttribute(position, true, points);
  d.attribute(id)->buffer()->Write(0, mesh.positions.data(), mesh.positions.size() * sizeof(Vec3f));
  for (const Triangle& t : mesh.triangles) d.AddFace({draco::PointIndex(t.v[0]), draco::PointIndex(t.v[1]), draco::PointIndex(t.v[2])});
  draco::Encoder encoder;
  encoder.SetEncodingMethod(method == "sequential" ? draco::MESH_SEQUENTIAL_ENCODING : draco::MESH_EDGEBREAKER_ENCODING);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
  encoder.SetSpeedOptions(speed, speed);
  draco::EncoderBuffer buffer;
  const draco::Status encoded = encoder.EncodeMeshToBuffer(d, &buffer);
  if (!encoded.ok()) {
    std::fprintf(stderr, "%s: %s\n", out, encoded.error_msg());
    return 3;
  }
  FILE* f = std::fopen(out, "wb");
  if (f == nullptr || std::fwrite(buffer.data(), 1, buffer.size(), f) != buffer.size() || std::fclose(f) != 0) {
    std::fprintf(stderr, "%s: cannot write\n", out);
    return 4;
  }
  return 0;
}

// One file, in this process: prints one row of the table.
int one(const char* path) {
  std::vector<char> head(1 << 16);
  FILE* f = std::fopen(path, "rb");
  if (f == nullptr) {
    std::fprintf(stderr, "%s: %s\n", path, std::strerror(errno));
    return 2;
  }
  head.resize(std::fread(head.data(), 1, head.size(), f));
  std::fseek(f, 0, SEEK_END);
  const long bytes = std::ftell(f);
  std::fclose(f);
  auto counts = format::read_draco_counts(head, path, static_cast<std::uint64_t>(bytes));
  if (!counts) {
    std::fprintf(stderr, "%s\n", counts.status().to_string().c_str());
    return 2;
  }
  const std::uint64_t before = stream::peak_rss();
  Count sink;
  format::Status s = format::read_mesh_file(path, {}, sink);
  if (!s.is_ok()) {
    std::fprintf(stderr, "%s\n", s.to_string().c_str());
    return 2;
  }
  const std::uint64_t after = stream::peak_rss();
  const double per_face = double(after - before) / double(counts->faces);
  std::printf("%-28s %-11s %10llu %10llu %9.2f %9.1f %9.1f %9.1f %9.1f\n", path,
              counts->method == format::DracoMethod::kSequential ? "sequential" : "edgebreaker",
              (unsigned long long)counts->faces, (unsigned long long)counts->points, bytes / 1e6, before / 1e6,
              after / 1e6, per_face, double(after - before - bytes) / double(counts->faces));
  return 0;
}

}  // namespace
}  // namespace gaussmesh::bench

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--one") == 0) return gaussmesh::bench::one(argv[2]);
  if ((argc == 5 || argc == 6) && std::strcmp(argv[1], "--encode") == 0) {
    return gaussmesh::bench::encode(argv[2], argv[3], argv[4], argc == 6 ? std::atoi(argv[5]) : 5);
  }
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_draco_decode FILE.drc...\n");
    return 1;
  }
  std::printf("%-28s %-11s %10s %10s %9s %9s %9s %9s %9s\n", "file", "method", "faces", "points", "file MB",
              "base MB", "peak MB", "B/face", "-file");
  std::fflush(stdout);
  int status = 0;
  for (int i = 1; i < argc; ++i) {
    const pid_t pid = fork();
    if (pid == 0) {
      execl("/proc/self/exe", argv[0], "--one", argv[i], static_cast<char*>(nullptr));
      _exit(127);
    }
    int wstatus = 0;
    waitpid(pid, &wstatus, 0);
    if (!WIFEXITED(wstatus) || WEXITSTATUS(wstatus) != 0) status = 2;
  }
  return status;
}
