// Benchmark of the sampler's per-face and per-vertex steps (paper §4) on a generated in-memory
// mesh: a closed, finely tessellated torus-like grid of N triangles with a little noise. Prints
// one line per step: wall seconds, CPU seconds (getrusage, all threads), million triangles per
// second of wall time. Each step runs twice: "cold" into new arrays (first touch of fresh
// pages, ~10-15 µs per 4 KiB here) and "warm" into the same, reused arrays (what a chunk loop
// with one workspace per thread pays).
// The summary lines give triangles per second of CPU time too (the figure to compare on a
// shared machine). STEPS_ONLY = 1 skips the whole-pass runs of sample_mesh. The last line of
// the steps gives a hash of every per-face array (normals, degenerate flags, areas, labels,
// feature bits) and of every vertex record (paper and exact), field by field: a change that
// must keep every decision shows the same hashes before and after.
// WARM_PASSES (default 1) repeats the warm steps (less noise on a shared machine; the profile
// of a step without the cold pass dominating).
// Usage: bench_sampler [TRIANGLES (default 20000000) | MESH_FILE] [FREQUENCY (default 8)] [THREADS (default 1)]
//                      [STEPS_ONLY (default 0)] [WARM_PASSES (default 1)]
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <vector>

#include <tbb/global_control.h>

#include "stream/core/mesh.h"
#include "stream/core/mesh_adjacency.h"
#include "stream/sampling/patch_filters.h"
#include "stream/sampling/sampler.h"

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

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Timer {
  using Clock = std::chrono::steady_clock;
  Clock::time_point wall = Clock::now();
  double cpu = cpu_seconds();
  std::size_t n = 0;
  // Prints the step since the last lap; returns its wall seconds.
  double last_cpu = 0;  // CPU seconds of the last lap
  double lap(const char* step) {
    const auto now = Clock::now();
    const double c = cpu_seconds();
    const double s = std::chrono::duration<double>(now - wall).count();
    std::printf("%-34s %8.3f s wall %8.3f s cpu %8.1f Mtri/s\n", step, s, c - cpu, double(n) / s / 1e6);
    wall = now;
    last_cpu = c - cpu;
    cpu = c;
    return s;
  }
};

// FNV-1a over bytes, fed value by value (no struct padding).
struct Hash {
  std::uint64_t h = 0xcbf29ce484222325ull;
  void bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x100000001b3ull;
  }
  template <typename T>
  void value(const T& v) {
    bytes(&v, sizeof v);
  }
};

std::uint64_t hash_floats(const std::vector<format::Vec3f>& v) {
  Hash h;
  for (const auto& x : v) h.value(x.x), h.value(x.y), h.value(x.z);
  return h.h;
}

template <typename T>
std::uint64_t hash_array(const std::vector<T>& v) {
  Hash h;
  h.bytes(v.data(), v.size() * sizeof(T));
  return h.h;
}

std::uint64_t hash_records(const std::vector<stream::VertexRecord>& records) {
  Hash h;
  for (const auto& r : records) {
    h.value(r.vertex), h.value(r.gauss_vertex), h.value(r.characteristic), h.value(r.winding);
    h.value(r.feature_edges), h.value(r.is_candidate), h.value(r.is_tree), h.value(r.is_exact_sample);
    h.value(r.enclosed), h.value(r.exact_gauss_vertex), h.value(r.exact_winding), h.value(r.exact_characteristic);
    h.value(r.cover_mask);
  }
  return h.h;
}

void print_patch_stage(const stream::SamplerWorkspace& ws) {
  const auto& p = ws.patch_seconds;
  std::printf("patch stage %.3f s wall %.3f s cpu: find_patches %.3f, patch graph input %.3f, merge rounds %.3f, "
              "result %.3f\n",
              p.wall, p.cpu(), p.find_patches, p.build, p.rounds, p.result);
}

}  // namespace

int main(int argc, char** argv) {
  const bool from_file = argc > 1 && !(argv[1][0] >= '0' && argv[1][0] <= '9');
  const std::size_t triangles = argc > 1 && !from_file ? std::strtoull(argv[1], nullptr, 10) : 20000000;
  const std::uint32_t frequency = argc > 2 ? static_cast<std::uint32_t>(std::strtoul(argv[2], nullptr, 10)) : 8;
  const int threads = argc > 3 ? std::atoi(argv[3]) : 1;
  const bool steps_only = argc > 4 && std::atoi(argv[4]) != 0;
  const int warm_passes = argc > 5 ? std::max(1, std::atoi(argv[5])) : 1;
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  Timer t;
  stream::Mesh mesh;
  if (from_file) {
    auto loaded = stream::load_mesh(argv[1]);
    if (!loaded) {
      std::fprintf(stderr, "bench_sampler: cannot read %s\n", argv[1]);
      return 2;
    }
    mesh = std::move(loaded).value();
  } else {
    mesh = make_grid_torus(triangles);
  }
  const std::size_t nf = mesh.triangles.size();
  const auto nv = static_cast<std::uint32_t>(mesh.positions.size());
  t.n = nf;
  std::printf("mesh: %u vertices, %zu triangles; G icosa f=%u; %d thread(s)\n", nv, nf, frequency, threads);
  t.lap("generate");
  stream::GaussSphereOptions go;
  go.frequency = frequency;
  const stream::GaussSphere g = stream::GaussSphere::create(go).value();

  stream::MeshAdjacency adj;
  stream::FaceNormals normals;
  std::vector<float> area;
  std::vector<format::Vec3f> smoothed;
  std::vector<std::uint32_t> labels;
  std::vector<std::uint8_t> feature;
  std::vector<stream::VertexRecord> paper, exact;
  stream::Patches patches;
  std::vector<std::uint32_t> stack;
  double s_adj = 0, s_face = 0, s_vertex = 0, s_exact = 0;
  double c_adj = 0, c_face = 0, c_vertex = 0, c_exact = 0;  // CPU seconds
  double c_normals = 0, c_labels = 0, c_feature = 0;
  for (int pass_index = 0; pass_index <= warm_passes; ++pass_index) {
    const char* pass = pass_index == 0 ? "cold" : "warm";
    std::printf("-- %s (%s arrays)\n", pass, pass[0] == 'c' ? "new" : "reused");
    t.lap("(setup)");
    if (!build_mesh_adjacency(mesh.view(), adj).is_ok()) return 1;
    s_adj = t.lap("adjacency (stars, fans)");
    c_adj = t.last_cpu;
    stream::compute_face_normals(mesh.view(), adj, 0, normals, area, smoothed);
    s_face = t.lap("face normals");
    c_face = c_normals = t.last_cpu;
    stream::compute_face_labels(normals, g, labels);
    s_face += t.lap("labels (locate)");
    c_face += c_labels = t.last_cpu;
    stream::compute_feature_edges(adj, labels, feature);
    s_face += t.lap("feature edges");
    c_face += c_feature = t.last_cpu;
    paper.clear();
    stream::evaluate_vertices(mesh.view(), adj, normals, labels, feature, g, false, 0, nv, paper);
    s_vertex = t.lap("vertices (paper decisions)");
    c_vertex = t.last_cpu;
    exact.clear();
    stream::evaluate_vertices(mesh.view(), adj, normals, labels, feature, g, true, 0, nv, exact);
    s_exact = t.lap("vertices (+ exact test)");
    c_exact = t.last_cpu;
    stream::find_patches(adj, labels, feature, patches, stack);
    t.lap("patches");
    std::printf("per-face + per-vertex steps: %.1f Mtri/s (adjacency excluded), %.1f Mtri/s (included); "
                "with the exact test instead of paper decisions: %.1f / %.1f\n",
                double(nf) / (s_face + s_vertex) / 1e6, double(nf) / (s_adj + s_face + s_vertex) / 1e6,
                double(nf) / (s_face + s_exact) / 1e6, double(nf) / (s_adj + s_face + s_exact) / 1e6);
    std::printf("  by CPU time: %.1f Mtri/s (adjacency excluded), %.1f Mtri/s (included); with the exact test: %.1f / %.1f\n",
                double(nf) / (c_face + c_vertex) / 1e6, double(nf) / (c_adj + c_face + c_vertex) / 1e6,
                double(nf) / (c_face + c_exact) / 1e6, double(nf) / (c_adj + c_face + c_exact) / 1e6);
    std::printf("  %s steps, CPU s: normals %.3f labels %.3f feature %.3f paper %.3f = %.3f (%.1f Mtri/s); exact %.3f\n",
                pass, c_normals, c_labels, c_feature, c_vertex, c_face + c_vertex, double(nf) / (c_face + c_vertex) / 1e6,
                c_exact);
  }
  std::printf("candidates %zu, exact records %zu, patches %zu\n", paper.size(), exact.size(), patches.patch_label.size());
  std::printf("hashes: normals %016llx degenerate %016llx area %016llx labels %016llx feature %016llx paper %016llx "
              "exact %016llx\n",
              static_cast<unsigned long long>(hash_floats(normals.normal)),
              static_cast<unsigned long long>(hash_array(normals.degenerate)),
              static_cast<unsigned long long>(hash_array(area)), static_cast<unsigned long long>(hash_array(labels)),
              static_cast<unsigned long long>(hash_array(feature)), static_cast<unsigned long long>(hash_records(paper)),
              static_cast<unsigned long long>(hash_records(exact)));
  if (steps_only) return 0;
  stream::SamplerOptions so;
  stream::SamplerWorkspace ws;
  stream::SamplingResult result;
  for (const char* pass : {"cold", "warm"}) {
    std::printf("-- whole pass, %s workspace\n", pass);
    t.lap("(setup)");
    so.sample_test = stream::SampleTest::kPaper;
    if (!stream::sample_mesh(mesh.view(), g, so, ws, result).is_ok()) return 1;
    t.lap("sample_mesh (paper, all)");
    std::printf("samples (paper) %zu, merged patches %zu in %zu rounds\n", result.samples.size(), result.stats.merged_patches, result.stats.merge_rounds);
    print_patch_stage(ws);
    t.lap("(print)");
    so.sample_test = stream::SampleTest::kExact;
    if (!stream::sample_mesh(mesh.view(), g, so, ws, result).is_ok()) return 1;
    t.lap("sample_mesh (exact, all)");
    std::printf("samples (exact) %zu\n", result.samples.size());
    print_patch_stage(ws);
  }
  return 0;
}
