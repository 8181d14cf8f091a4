// Prints the paper's Fig. 18 experiment as a table: every real fixture simplified with eight
// random orientations of G (per-patch mesher), with output size and error against the input.
// Usage: simplify_table [--frequency F] [--smooth N] [--sample-test exact|paper] [--mesher patch|voronoi] [FILES...]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "stream/analysis/mesh_distance.h"
#include "stream/core/mesh_topology.h"
#include "stream/pipeline/in_core_simplify.h"
#include "tests/support/test_util.h"

using namespace gaussmesh;

int main(int argc, char** argv) {
  stream::SimplifyOptions options;
  options.spheres[0].frequency = 4;
  std::vector<std::string> files;
  int orientations = 8;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    auto next = [&] { return std::string(i + 1 < argc ? argv[++i] : ""); };
    if (arg == "--frequency") options.spheres[0].frequency = std::stoul(next());
    else if (arg == "--smooth") options.sampler.smooth_iterations = std::stoul(next());
    else if (arg == "--sample-test") options.sampler.sample_test = next() == "paper" ? stream::SampleTest::kPaper : stream::SampleTest::kExact;
    else if (arg == "--mesher") options.mesher = next() == "voronoi" ? stream::MesherKind::kVoronoi : stream::MesherKind::kPatch;
    else if (arg == "--orientations") orientations = std::stoi(next());
    else files.push_back(arg);
  }
  if (files.empty()) {
    for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "mushroom.off", "bunny-lowres.ply"}) {
      files.push_back(testing::fixture(std::string("real/") + name));
    }
  }
  std::printf("| mesh | orientation | input faces | samples | output faces | Hausdorff %% | RMS %% | χ in/out | seconds |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
  for (const auto& file : files) {
    auto mesh = stream::load_mesh(file);
    if (!mesh) {
      std::fprintf(stderr, "%s\n", mesh.status().to_string().c_str());
      return 2;
    }
    auto in_topology = stream::compute_topology(mesh->view());
    double worst = 0;
    for (int k = 1; k <= orientations; ++k) {
      options.spheres[0].rotation = stream::gauss_rotation_from_seed(k);
      auto start = std::chrono::steady_clock::now();
      auto result = stream::simplify_mesh(mesh->view(), options);
      double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (!result) {
        std::fprintf(stderr, "%s: %s\n", file.c_str(), result.status().to_string().c_str());
        return 3;
      }
      auto distance = stream::mesh_distance(mesh->view(), result->mesh.view());
      auto out_topology = stream::compute_topology(result->mesh.view());
      double h = distance ? distance->hausdorff_pct() : -1, r = distance ? distance->rms_pct() : -1;
      worst = std::max(worst, h);
      std::string name = file.substr(file.rfind('/') + 1);
      std::printf("| %s | seed %d | %zu | %zu | %zu | %.2f | %.3f | %lld/%lld | %.2f |\n", name.c_str(), k,
                  mesh->triangles.size(), result->samples, result->mesh.triangles.size(), h, r,
                  in_topology->euler_characteristic, out_topology->euler_characteristic, seconds);
    }
    std::fprintf(stderr, "%s: worst Hausdorff %.2f%%\n", file.c_str(), worst);
  }
  return 0;
}
