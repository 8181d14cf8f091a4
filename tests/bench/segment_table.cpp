// Prints docs/segment.md's table: spherical segmentation (paper §6) of the analytic shapes in
// several random orientations and of the genus-0/1 fixtures over several Gaussian-sphere
// orientations: segments, faces per segment, smoothing iterations, poles, merges.
// Usage: segment_table [frequency=2] [orientations=8] [smoothing cap] [--write DIR] (DIR: a coloured PLY
// of every orientation, which scripts/render-figures draws in the viewer).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/core/mesh.h"
#include "stream/analysis/segmentation.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

using namespace gaussmesh;

namespace {

struct Case {
  std::string name;
  std::uint32_t expected;
  bool analytic;  // rotate the shape; else rotate G
  std::function<stream::Mesh(std::uint64_t seed)> make;
};

void write_coloured(const std::string& path, const stream::Mesh& mesh, const stream::SegmentationResult& r) {
  static const std::uint8_t palette[][3] = {{220, 50, 47}, {60, 170, 60}, {38, 110, 210}, {230, 190, 30}, {160, 80, 200}};
  const std::size_t nf = mesh.triangles.size();
  std::vector<std::uint8_t> red(nf), green(nf), blue(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto* c = palette[r.face_segment[f] % 5];
    const int dim = r.face_pole[f] ? 40 : 0;  // pole faces slightly darker (Fig. 20, second step)
    red[f] = static_cast<std::uint8_t>(c[0] - c[0] * dim / 255);
    green[f] = static_cast<std::uint8_t>(c[1] - c[1] * dim / 255);
    blue[f] = static_cast<std::uint8_t>(c[2] - c[2] * dim / 255);
  }
  auto out = format::OutputFile::create(path, true);
  if (!out) return;
  format::PlyWriteOptions o;
  o.face_attributes = {{"red", std::span<const std::uint8_t>(red)},
                       {"green", std::span<const std::uint8_t>(green)},
                       {"blue", std::span<const std::uint8_t>(blue)},
                       {"segment", std::span<const std::uint32_t>(r.face_segment)}};
  if (format::write_ply(**out, mesh.view(), o)) (void)(*out)->commit();
}

}  // namespace

int main(int argc, char** argv) {
  std::uint32_t frequency = 2, orientations = 8;
  std::string write_dir;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--write") == 0 && i + 1 < argc) write_dir = argv[++i];
    else positional.push_back(argv[i]);
  }
  if (positional.size() > 0) frequency = static_cast<std::uint32_t>(std::atoi(positional[0].c_str()));
  if (positional.size() > 1) orientations = static_cast<std::uint32_t>(std::atoi(positional[1].c_str()));
  stream::SegmentationOptions options;
  if (positional.size() > 2) options.max_smooth = static_cast<std::uint32_t>(std::atoi(positional[2].c_str()));

  auto shape = [](auto generator) {
    return [generator](std::uint64_t seed) {
      testing::ShapeOptions o;
      o.rotation = testing::random_rotation(seed);
      return generator(o);
    };
  };
  auto fixture = [](const std::string& name) {
    return [name](std::uint64_t) { return stream::load_mesh(testing::fixture("real/" + name)).value(); };
  };
  std::vector<Case> cases = {
      {"sphere", 1, true, shape([](testing::ShapeOptions o) { o.vertices = 5000; return testing::make_sphere(o); })},
      {"rounded cube p=6", 1, true,
       shape([](testing::ShapeOptions o) { o.vertices = 8000; return testing::make_rounded_cube(6, o); })},
      {"thin torus r/R=0.25", 2, true,
       shape([](testing::ShapeOptions o) { o.vertices = 6000; return testing::make_torus(1, 0.25, o); })},
      {"thick torus r/R=0.7", 2, true,
       shape([](testing::ShapeOptions o) { o.vertices = 6000; return testing::make_torus(1, 0.7, o); })},
      {"genus 2", 3, true, shape([](testing::ShapeOptions o) { o.vertices = 8000; return testing::make_genus2(o); })},
      {"cow.off", 1, false, fixture("cow.off")},
      {"knot1.off", 2, false, fixture("knot1.off")},
  };

  std::printf("G: icosahedron, frequency %u (%u triangles); %u orientations (seeds 1..%u); smoothing cap %u\n\n",
              frequency, 20 * frequency * frequency, orientations, orientations, options.max_smooth);
  std::printf("| shape | faces | genus | expected | segments (per orientation) | faces per segment (orientation 1) | smoothing iterations | poles | greedy aggregates | merges | duplicate labels | ms |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    std::string segs, faces, iters, poles, greedy, merges, dups;
    std::size_t nf = 0, genus = 0;
    double ms = 0;
    bool all_ok = true;
    for (std::uint64_t seed = 1; seed <= orientations; ++seed) {
      const stream::Mesh mesh = c.make(seed);
      stream::GaussSphereOptions go;
      go.frequency = frequency;
      if (!c.analytic) go.rotation = stream::gauss_rotation_from_seed(seed);
      const auto gauss = stream::GaussSphere::create(go).value();
      const auto t0 = std::chrono::steady_clock::now();
      auto r = stream::segment_mesh(mesh.view(), gauss, options);
      ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (!r) {
        std::printf("| %s | error: %s |\n", c.name.c_str(), r.status().to_string().c_str());
        all_ok = false;
        break;
      }
      nf = mesh.triangles.size();
      genus = r->genus;
      auto add = [](std::string& s, const std::string& v) { s += (s.empty() ? "" : " ") + v; };
      add(segs, std::to_string(r->segment_count) + (r->segment_count == c.expected ? "" : "!"));
      add(iters, std::to_string(r->smooth_iterations) + (r->smooth_cap_hit ? "(cap)" : ""));
      add(poles, std::to_string(r->poles));
      add(greedy, std::to_string(r->greedy_aggregates));
      add(merges, std::to_string(r->merges));
      std::size_t d = 0;
      for (std::size_t x : r->duplicate_labels) d += x;
      add(dups, std::to_string(d));
      if (seed == 1) {
        for (std::size_t s = 0; s < r->segment_count; ++s) add(faces, std::to_string(r->segment_faces[s]));
      }
      if (!write_dir.empty()) {
        std::string file = c.name;
        for (char& ch : file) {
          if (ch == ' ' || ch == '/' || ch == '=' || ch == '.') ch = '_';
        }
        write_coloured(write_dir + "/" + file + "-" + std::to_string(seed) + ".ply", mesh, *r);
      }
    }
    if (!all_ok) continue;
    std::printf("| %s | %zu | %zu | %u | %s | %s | %s | %s | %s | %s | %s | %.0f |\n", c.name.c_str(), nf, genus,
                c.expected, segs.c_str(), faces.c_str(), iters.c_str(), poles.c_str(), greedy.c_str(), merges.c_str(),
                dups.c_str(), ms / orientations);
  }
  return 0;
}
