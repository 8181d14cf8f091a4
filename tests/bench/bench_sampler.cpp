// Benchmark of the sampler's per-face and per-vertex steps (paper §4) on a generated in-memory
// mesh: a closed, finely tessellated torus-like grid of N triangles with a little noise. Prints
// one line per step (seconds, million triangles per second, one core).
// Usage: bench_sampler [TRIANGLES (default 20000000)] [FREQUENCY (default 8)]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>

#include "stream/mesh.h"
#include "stream/mesh_adjacency.h"
#include "stream/patch_filters.h"
#include "stream/sampler.h"

namespace {

using namespace gaussmesh;
using stream::Mesh;

// A (nu × nv) torus grid, two triangles per quad, positions wobbled by a deterministic hash.
Mesh make_grid_torus(std::size_t triangles) {
  const std::size_t quads = triangles / 2;
  const std::size_t nv = static_cast<std::size_t>(std::sqrt(double(quads) / 3.0));
  const std::size_t nu = quads / nv;
  Mesh m;
  m.positions.resize(nu * nv);
  for (std::size_t j = 0; j < nv; ++j)
    for (std::size_t i = 0; i < nu; ++i) {
      const double u = 2 * std::numbers::pi * double(i) / double(nu), v = 2 * std::numbers::pi * double(j) / double(nv);
      std::uint64_t h = (j * nu + i) * 0x9E3779B97F4A7C15ull;
      h ^= h >> 29;
      const double wobble = 1 + 1e-4 * (double(h & 0xFFFF) / 65535.0 - 0.5);
      const double rho = 3 + std::cos(v);
      m.positions[j * nu + i] = {float(rho * std::cos(u) * wobble), float(rho * std::sin(u) * wobble),
                                 float(std::sin(v) * wobble)};
    }
  m.triangles.reserve(2 * nu * nv);
  for (std::size_t j = 0; j < nv; ++j)
    for (std::size_t i = 0; i < nu; ++i) {
      auto id = [&](std::size_t a, std::size_t b) { return static_cast<format::VertexIndex>((b % nv) * nu + (a % nu)); };
      m.triangles.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      m.triangles.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  const std::size_t triangles = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 20000000;
  const std::uint32_t frequency = argc > 2 ? static_cast<std::uint32_t>(std::strtoul(argv[2], nullptr, 10)) : 8;
  using Clock = std::chrono::steady_clock;
  auto t = Clock::now();
  const Mesh mesh = make_grid_torus(triangles);
  auto lap = [&t](const char* step, std::size_t n) {
    const auto now = Clock::now();
    const double s = std::chrono::duration<double>(now - t).count();
    std::printf("%-28s %8.3f s %10.1f Mtri/s\n", step, s, double(n) / s / 1e6);
    t = now;
    return s;
  };
  const std::size_t nf = mesh.triangles.size();
  std::printf("mesh: %zu vertices, %zu triangles; G icosa f=%u\n", mesh.positions.size(), nf, frequency);
  lap("generate", nf);
  stream::GaussSphereOptions go;
  go.frequency = frequency;
  const stream::GaussSphere g = stream::GaussSphere::create(go).value();
  auto adj = stream::build_mesh_adjacency(mesh.view());
  if (!adj) return 1;
  const double s_adj = lap("adjacency (stars, fans)", nf);
  const auto normals = stream::compute_face_normals(mesh.view(), *adj, 0);
  double s_face = lap("face normals", nf);
  const auto labels = stream::compute_face_labels(normals, g);
  s_face += lap("labels (locate)", nf);
  const auto feature = stream::compute_feature_edges(*adj, labels);
  s_face += lap("feature edges", nf);
  std::vector<stream::VertexRecord> paper, exact;
  stream::evaluate_vertices(mesh.view(), *adj, normals, labels, feature, g, false, 0,
                            static_cast<std::uint32_t>(mesh.positions.size()), paper);
  const double s_vertex = lap("vertices (paper decisions)", nf);
  stream::evaluate_vertices(mesh.view(), *adj, normals, labels, feature, g, true, 0,
                            static_cast<std::uint32_t>(mesh.positions.size()), exact);
  lap("vertices (+ exact test)", nf);
  const auto patches = stream::find_patches(*adj, labels, feature);
  lap("patches", nf);
  std::printf("candidates %zu, exact records %zu, patches %zu\n", paper.size(), exact.size(), patches.patch_label.size());
  std::printf("per-face + per-vertex steps: %.1f Mtri/s (adjacency excluded), %.1f Mtri/s (included)\n",
              double(nf) / (s_face + s_vertex) / 1e6, double(nf) / (s_adj + s_face + s_vertex) / 1e6);
  stream::SamplerOptions so;
  so.sample_test = stream::SampleTest::kPaper;
  t = Clock::now();
  auto whole = stream::sample_mesh(mesh.view(), g, so);
  lap("sample_mesh (paper, all)", nf);
  so.sample_test = stream::SampleTest::kExact;
  whole = stream::sample_mesh(mesh.view(), g, so);
  lap("sample_mesh (exact, all)", nf);
  std::printf("samples (exact) %zu\n", whole->samples.size());
  return 0;
}
