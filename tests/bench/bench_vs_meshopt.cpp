// Benchmark table for docs/meshing.md: gaussmesh's in-core simplify against meshoptimizer's
// meshopt_simplify and meshopt_simplifySloppy at the same output face count, on the real
// fixtures (or the files given): output faces, Hausdorff and RMS (% of the input's bounding-box
// diagonal, gaussmesh compare's measure) and time. meshoptimizer is a benchmark-only dependency.
// Usage: bench_vs_meshopt [--frequency F] [FILES...]
#include <meshoptimizer.h>

#include <cstdio>
#include <string>
#include <vector>

#include "stream/analysis/mesh_distance.h"
#include "stream/core/stopwatch.h"
#include "stream/pipeline/in_core_simplify.h"
#include "tests/support/test_util.h"

using namespace gaussmesh;

namespace {

using stream::seconds_since;

stream::Mesh from_indices(const stream::Mesh& input, const std::vector<unsigned>& indices) {
  stream::Mesh out;
  out.positions = input.positions;  // unreferenced vertices do not affect the distance
  for (size_t i = 0; i + 2 < indices.size(); i += 3) out.triangles.push_back({{indices[i], indices[i + 1], indices[i + 2]}});
  return out;
}

void row(const std::string& name, const char* method, const stream::Mesh& input, const stream::Mesh& output,
         double seconds) {
  auto d = stream::mesh_distance(input.view(), output.view());
  std::printf("| %s | %s | %zu | %zu | %.2f | %.3f | %.1f |\n", name.c_str(), method, input.triangles.size(),
              output.triangles.size(), d ? d->hausdorff_pct() : -1.0, d ? d->rms_pct() : -1.0, seconds * 1000);
}

}  // namespace

int main(int argc, char** argv) {
  stream::SimplifyOptions options;
  options.spheres[0].frequency = 4;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--frequency" && i + 1 < argc) {
      options.spheres[0].frequency = std::stoul(argv[++i]);
    } else {
      files.push_back(arg);
    }
  }
  if (files.empty()) {
    for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "mushroom.off", "bunny-lowres.ply"}) {
      files.push_back(testing::fixture(std::string("real/") + name));
    }
  }
  std::printf("| mesh | method | input faces | output faces | Hausdorff %% | RMS %% | ms |\n| --- | --- | --- | --- | --- | --- | --- |\n");
  for (const auto& file : files) {
    std::string name = file.substr(file.rfind('/') + 1);
    auto mesh = stream::load_mesh(file);
    if (!mesh) {
      std::fprintf(stderr, "%s\n", mesh.status().to_string().c_str());
      return 2;
    }
    auto start = stream::Clock::now();
    auto ours = stream::simplify_mesh(mesh->view(), options);
    double ours_seconds = seconds_since(start);
    if (!ours) {
      std::fprintf(stderr, "%s\n", ours.status().to_string().c_str());
      return 3;
    }
    row(name, "gaussmesh (patch, f=4)", *mesh, ours->mesh, ours_seconds);
    const size_t target = ours->mesh.triangles.size() * 3;
    std::vector<unsigned> indices;
    for (const auto& t : mesh->triangles) indices.insert(indices.end(), {t.v[0], t.v[1], t.v[2]});
    std::vector<unsigned> out(indices.size());
    const float* xyz = &mesh->positions[0].x;
    start = stream::Clock::now();
    float error = 0;
    size_t n = meshopt_simplify(out.data(), indices.data(), indices.size(), xyz, mesh->positions.size(),
                                sizeof(format::Vec3f), target, 1.0f, 0, &error);
    double seconds = seconds_since(start);
    row(name, "meshopt_simplify", *mesh, from_indices(*mesh, {out.begin(), out.begin() + n}), seconds);
    start = stream::Clock::now();
    n = meshopt_simplifySloppy(out.data(), indices.data(), indices.size(), xyz, mesh->positions.size(),
                               sizeof(format::Vec3f), target, 1.0f, &error);
    seconds = seconds_since(start);
    row(name, "meshopt_simplifySloppy", *mesh, from_indices(*mesh, {out.begin(), out.begin() + n}), seconds);
  }
  return 0;
}
