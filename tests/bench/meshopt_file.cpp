// The whole job a meshoptimizer user would run on a mesh file, for the pipeline benchmark: read
// it (our streaming readers, into memory), meshopt_simplify or meshopt_simplifySloppy, drop the
// unreferenced vertices, write a binary PLY. meshoptimizer is a benchmark-only dependency.
//
//   meshopt_file IN --ratio R | --target-faces N [--sloppy] [--target-error E] [-o OUT.ply]
//
// Prints one line on stdout, key=value pairs the benchmark driver parses:
//   read_s simplify_s write_s input_faces output_faces output_vertices result_error peak_rss_mb
// --target-error defaults to 1.0 (relative to the mesh extent): only the face count stops it.
// Exit codes: 0 ok, 1 usage, 2 bad input, 3 simplification, 4 output.
#include <meshoptimizer.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/core/mesh.h"
#include "stream/core/process_memory.h"
#include "stream/core/stopwatch.h"

namespace gaussmesh::bench {
namespace {

using format::Status;
using format::Triangle;
using stream::Clock;
using stream::seconds_since;

// The triangle array is handed to meshoptimizer as its flat index buffer, without a copy.
static_assert(sizeof(Triangle) == 3 * sizeof(unsigned int) && alignof(Triangle) == alignof(unsigned int));

int usage() {
  std::fprintf(stderr,
               "usage: meshopt_file IN --ratio R | --target-faces N [--sloppy] [--target-error E] [-o OUT.ply]\n");
  return 1;
}

int fail(const Status& status) {
  std::fprintf(stderr, "meshopt_file: %s\n", status.to_string().c_str());
  return int(status.code());
}

// Keeps the vertices that out_faces use, renumbered in first-use order; rewrites out_faces.
std::vector<format::Vec3f> compact(const std::vector<format::Vec3f>& positions, std::vector<Triangle>& out_faces) {
  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> remap(positions.size(), kUnused);
  std::vector<format::Vec3f> kept;
  for (Triangle& t : out_faces) {
    for (std::uint32_t& v : t.v) {
      if (remap[v] == kUnused) {
        remap[v] = std::uint32_t(kept.size());
        kept.push_back(positions[v]);
      }
      v = remap[v];
    }
  }
  return kept;
}

}  // namespace
}  // namespace gaussmesh::bench

int main(int argc, char** argv) {
  using namespace gaussmesh;
  using namespace gaussmesh::bench;
  std::string input, output;
  double ratio = 0;
  std::uint64_t target_faces = 0;
  float target_error = 1.0f;
  bool sloppy = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--sloppy") {
      sloppy = true;
      continue;
    }
    if (arg.size() > 1 && arg[0] == '-') {
      if (i + 1 >= argc) return usage();
      std::string value = argv[++i];
      char* end = nullptr;
      if (arg == "--ratio") {
        ratio = std::strtod(value.c_str(), &end);
      } else if (arg == "--target-faces") {
        target_faces = std::strtoull(value.c_str(), &end, 10);
      } else if (arg == "--target-error") {
        target_error = std::strtof(value.c_str(), &end);
      } else if (arg == "-o" || arg == "--output") {
        output = value;
      } else {
        return usage();
      }
      if (end != nullptr && (*end != '\0' || value.empty())) return usage();
    } else if (input.empty()) {
      input = arg;
    } else {
      return usage();
    }
  }
  if (input.empty() || (ratio > 0) == (target_faces > 0) || ratio > 1 || !(target_error >= 0)) return usage();

  auto t = Clock::now();
  auto mesh = stream::load_mesh(input);
  if (!mesh) return fail(mesh.status());
  const double read_s = seconds_since(t);
  for (const Triangle& tri : mesh->triangles) {
    for (std::uint32_t v : tri.v) {
      if (v >= mesh->positions.size()) {
        return fail(Status::error(format::Code::kBadInput, input, "face index out of range"));
      }
    }
  }
  const size_t input_faces = mesh->triangles.size();
  if (ratio > 0) target_faces = std::uint64_t(double(input_faces) * ratio);

  t = Clock::now();
  std::vector<Triangle> out_faces(input_faces);
  const auto* indices = reinterpret_cast<const unsigned int*>(mesh->triangles.data());
  auto* destination = reinterpret_cast<unsigned int*>(out_faces.data());
  const float* xyz = &mesh->positions.data()->x;
  float result_error = 0;
  const size_t index_count = sloppy
      ? meshopt_simplifySloppy(destination, indices, input_faces * 3, xyz, mesh->positions.size(),
                               sizeof(format::Vec3f), target_faces * 3, target_error, &result_error)
      : meshopt_simplify(destination, indices, input_faces * 3, xyz, mesh->positions.size(), sizeof(format::Vec3f),
                         target_faces * 3, target_error, 0, &result_error);
  out_faces.resize(index_count / 3);
  out_faces.shrink_to_fit();
  const double simplify_s = seconds_since(t);
  if (out_faces.empty()) return fail(Status::error(format::Code::kProcessing, input, "no faces left"));

  t = Clock::now();
  std::vector<format::Vec3f> kept = compact(mesh->positions, out_faces);
  if (!output.empty()) {
    auto file = format::OutputFile::create(output, true);
    if (!file) return fail(file.status());
    format::PlyWriteOptions ply;
    ply.comments.push_back(std::string("meshopt_file ") + (sloppy ? "meshopt_simplifySloppy" : "meshopt_simplify"));
    Status status = format::write_ply(**file, {kept, out_faces}, ply);
    if (status) status = (*file)->commit();
    if (!status) return fail(status);
  }
  const double write_s = seconds_since(t);
  std::printf("read_s=%.3f simplify_s=%.3f write_s=%.3f input_faces=%zu output_faces=%zu output_vertices=%zu "
              "result_error=%.6g peak_rss_mb=%.1f\n",
              read_s, simplify_s, write_s, input_faces, out_faces.size(), kept.size(), double(result_error),
              double(stream::peak_rss()) / 1e6);
  return 0;
}
