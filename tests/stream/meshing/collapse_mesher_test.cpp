// Tests of the per-patch meshers — the collapse mesher (mesh_patches_by_collapse) and the
// polygon-first mesher (mesh_patch_polygons) run the same tests: topology is kept, samples
// survive, no degenerate or duplicate faces, on tiny meshes built in code with a stand-in
// labelling (octant of the face normal).
#include "stream/meshing/collapse_mesher.h"
#include "stream/meshing/polygon_mesher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <set>

namespace gaussmesh::stream {
namespace {

constexpr double kPi = 3.14159265358979323846;

Mesh torus_grid(int nu, int nv, double major, double minor) {
  Mesh m;
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      double u = 2 * kPi * i / nu, v = 2 * kPi * j / nv;
      m.positions.push_back({float((major + minor * std::cos(v)) * std::cos(u)),
                             float((major + minor * std::cos(v)) * std::sin(u)), float(minor * std::sin(v))});
    }
  }
  auto id = [&](int i, int j) { return format::VertexIndex(((i + nu) % nu) * nv + (j + nv) % nv); };
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      m.triangles.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  }
  return m;
}

// A latitude/longitude sphere; `cap` > 0 cuts a hole of that many rings at the north pole.
Mesh uv_sphere(int rings, int segments, int cap = 0) {
  Mesh m;
  m.positions.push_back({0, 0, -1});
  for (int r = 1; r < rings; ++r) {
    double theta = kPi * r / rings - kPi / 2;
    for (int s = 0; s < segments; ++s) {
      double phi = 2 * kPi * (s + 0.37 * r) / segments;
      m.positions.push_back({float(std::cos(theta) * std::cos(phi)), float(std::cos(theta) * std::sin(phi)),
                             float(std::sin(theta))});
    }
  }
  m.positions.push_back({0, 0, 1});
  auto ring = [&](int r, int s) { return format::VertexIndex(1 + (r - 1) * segments + (s + segments) % segments); };
  format::VertexIndex north = format::VertexIndex(m.positions.size() - 1);
  for (int s = 0; s < segments; ++s) m.triangles.push_back({{0, ring(1, s + 1), ring(1, s)}});
  for (int r = 1; r < rings - 1 - cap; ++r) {
    for (int s = 0; s < segments; ++s) {
      m.triangles.push_back({{ring(r, s), ring(r, s + 1), ring(r + 1, s + 1)}});
      m.triangles.push_back({{ring(r, s), ring(r + 1, s + 1), ring(r + 1, s)}});
    }
  }
  if (cap == 0) {
    for (int s = 0; s < segments; ++s) m.triangles.push_back({{ring(rings - 1, s), ring(rings - 1, s + 1), north}});
  }
  return m;
}

// Stand-in for the sampler: label = octant of the normal in a tilted frame; patches are the
// labels' connected components; vertices with >= 3 feature edges are samples.
struct Labelled {
  std::vector<std::uint32_t> face_patch;
  std::vector<VertexRole> role;
};

Labelled octant_labels(const Mesh& m) {
  Labelled out;
  const std::array<double, 3> a{0.8, 0.36, 0.48}, b{-0.6, 0.48, 0.64}, c{0, -0.8, 0.6};
  for (const auto& t : m.triangles) {
    auto p = [&](int k) { return m.positions[t.v[k]]; };
    double ux = p(1).x - p(0).x, uy = p(1).y - p(0).y, uz = p(1).z - p(0).z;
    double vx = p(2).x - p(0).x, vy = p(2).y - p(0).y, vz = p(2).z - p(0).z;
    double n[3] = {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
    auto d = [&](const std::array<double, 3>& e) { return n[0] * e[0] + n[1] * e[1] + n[2] * e[2] > 0; };
    out.face_patch.push_back(std::uint32_t(d(a)) | std::uint32_t(d(b)) << 1 | std::uint32_t(d(c)) << 2);
  }
  // Patches are edge-connected, as the sampler's are: each octant's components get ids of their
  // own, numbered by lowest face.
  std::map<std::pair<format::VertexIndex, format::VertexIndex>, std::vector<std::uint32_t>> faces_of;
  for (std::uint32_t f = 0; f < m.triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) faces_of[std::minmax(m.triangles[f].v[k], m.triangles[f].v[(k + 1) % 3])].push_back(f);
  }
  std::vector<std::uint32_t> parent(m.triangles.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (auto& [e, fs] : faces_of) {
    if (fs.size() == 2 && out.face_patch[fs[0]] == out.face_patch[fs[1]]) {
      const std::uint32_t a = find(fs[0]), b = find(fs[1]);
      parent[std::max(a, b)] = std::min(a, b);
    }
  }
  for (std::uint32_t f = 0; f < m.triangles.size(); ++f) out.face_patch[f] = find(f);
  // Count feature edges per vertex.
  std::map<std::pair<format::VertexIndex, format::VertexIndex>, std::vector<std::uint32_t>> edges;
  for (size_t f = 0; f < m.triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      auto x = m.triangles[f].v[k], y = m.triangles[f].v[(k + 1) % 3];
      edges[std::minmax(x, y)].push_back(out.face_patch[f]);
    }
  }
  std::vector<int> degree(m.positions.size(), 0);
  for (auto& [e, patches] : edges) {
    if (patches.size() != 2 || patches[0] != patches[1]) {
      ++degree[e.first];
      ++degree[e.second];
    }
  }
  for (int d : degree) out.role.push_back(d >= 3 ? VertexRole::kSample : VertexRole::kNone);
  return out;
}

struct Topology {
  size_t boundary_edges = 0, non_manifold_edges = 0, edges = 0;
  long euler = 0;
  size_t degenerate = 0, duplicates = 0;
};

Topology topology(const Mesh& m) {
  Topology t;
  std::map<std::pair<format::VertexIndex, format::VertexIndex>, int> edges;
  std::set<std::array<format::VertexIndex, 3>> faces;
  std::set<format::VertexIndex> used;
  for (const auto& tri : m.triangles) {
    std::array<format::VertexIndex, 3> key{tri.v[0], tri.v[1], tri.v[2]};
    if (key[0] == key[1] || key[1] == key[2] || key[0] == key[2]) ++t.degenerate;
    std::sort(key.begin(), key.end());
    if (!faces.insert(key).second) ++t.duplicates;
    for (int k = 0; k < 3; ++k) {
      used.insert(tri.v[k]);
      edges[std::minmax(tri.v[k], tri.v[(k + 1) % 3])]++;
    }
  }
  for (auto& [e, n] : edges) {
    if (n == 1) ++t.boundary_edges;
    if (n > 2) ++t.non_manifold_edges;
  }
  t.edges = edges.size();
  t.euler = long(used.size()) - long(edges.size()) + long(m.triangles.size());
  return t;
}

double min_area(const Mesh& m) {
  double smallest = 1e300;
  for (const auto& t : m.triangles) {
    auto p = [&](int k) { return m.positions[t.v[k]]; };
    double ux = p(1).x - p(0).x, uy = p(1).y - p(0).y, uz = p(1).z - p(0).z;
    double vx = p(2).x - p(0).x, vy = p(2).y - p(0).y, vz = p(2).z - p(0).z;
    double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
    smallest = std::min(smallest, 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz));
  }
  return smallest;
}

void expect_valid_approximation(const Mesh& input, const Labelled& labels, const PatchMesherResult& r) {
  Topology before = topology(input), after = topology(r.mesh);
  EXPECT_EQ(after.euler, before.euler);
  EXPECT_EQ(after.non_manifold_edges, 0u);
  EXPECT_EQ(after.degenerate, 0u);
  EXPECT_EQ(after.duplicates, 0u);
  EXPECT_EQ(after.boundary_edges == 0, before.boundary_edges == 0);
  EXPECT_GT(min_area(r.mesh), 0.0);
  ASSERT_EQ(r.birth.size(), r.mesh.positions.size());
  size_t samples = 0;
  for (auto role : labels.role) samples += role == VertexRole::kSample ? 1 : 0;
  EXPECT_EQ(r.kept_samples, samples);
  for (size_t i = 0; i < r.birth.size(); ++i) {
    EXPECT_EQ(r.mesh.positions[i], input.positions[r.birth[i]]) << "output vertex " << i << " moved";
  }
  EXPECT_LT(r.mesh.triangles.size(), input.triangles.size());
}

// Runs the mesher the test is instantiated for.
class Meshers : public ::testing::TestWithParam<std::string> {
 protected:
  format::Result<PatchMesherResult> run(const PatchMesherInput& input) const {
    if (GetParam() == "collapse") return mesh_patches_by_collapse(input);
    auto result = mesh_patch_polygons(input);
    if (!result) return result.status();
    return std::move(result->mesh);
  }
  bool is_polygon() const { return GetParam() == "polygon"; }
};

TEST_P(Meshers, ClosedSphereStaysClosedGenusZero) {
  Mesh sphere = uv_sphere(40, 64);
  Labelled labels = octant_labels(sphere);
  auto result = run({sphere.view(), labels.face_patch, labels.role});
  ASSERT_TRUE(result.is_ok()) << result.status().to_string();
  expect_valid_approximation(sphere, labels, *result);
  EXPECT_EQ(result->skipped_input_faces, 0u);
  EXPECT_GE(result->graph.chains, 6u);
  // Patches are triangulated in their plane; the collapse triangulation is the exception.
  EXPECT_GT(result->planar_patches, 0u);
  EXPECT_LE(result->collapse_patches, result->planar_patches / 10);
  if (is_polygon()) {
    EXPECT_EQ(result->collapse_patches, 0u);
  }
}

TEST_P(Meshers, TorusKeepsGenusOne) {
  Mesh torus = torus_grid(60, 30, 1.0, 0.35);
  Labelled labels = octant_labels(torus);
  auto result = run({torus.view(), labels.face_patch, labels.role});
  ASSERT_TRUE(result.is_ok()) << result.status().to_string();
  expect_valid_approximation(torus, labels, *result);
  EXPECT_EQ(topology(result->mesh).euler, 0);
}

TEST_P(Meshers, HoleWithFeatureVerticesSurvives) {
  Mesh open = uv_sphere(40, 64, 6);
  ASSERT_GT(topology(open).boundary_edges, 0u);
  Labelled labels = octant_labels(open);
  auto result = run({open.view(), labels.face_patch, labels.role});
  ASSERT_TRUE(result.is_ok()) << result.status().to_string();
  expect_valid_approximation(open, labels, *result);
  EXPECT_EQ(result->graph.boundary_loops, 1u);
  EXPECT_GE(topology(result->mesh).boundary_edges, 3u);
}

TEST_P(Meshers, OnePatchWithoutCornersKeepsAGuardTriangle) {
  // Every face in one patch and no samples: the only feature loop is the hole's boundary,
  // which must keep three vertices rather than vanish.
  Mesh open = uv_sphere(20, 24, 3);
  std::vector<std::uint32_t> one_patch(open.triangles.size(), 7);
  std::vector<VertexRole> none(open.positions.size(), VertexRole::kNone);
  auto result = run({open.view(), one_patch, none});
  ASSERT_TRUE(result.is_ok()) << result.status().to_string();
  Topology after = topology(result->mesh);
  EXPECT_EQ(after.euler, topology(open).euler);
  EXPECT_GE(after.boundary_edges, 3u);
  EXPECT_EQ(after.degenerate, 0u);
  EXPECT_GE(result->kept_chain_vertices, 3u);
}

TEST_P(Meshers, FlatSquareKeepsItsFourCorners) {
  // One patch, no samples: only the boundary's turns hold the shape (a square, not a triangle).
  Mesh square;
  const int n = 20;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) square.positions.push_back({float(i), float(j), 0});
  }
  for (int i = 0; i + 1 < n; ++i) {
    for (int j = 0; j + 1 < n; ++j) {
      format::VertexIndex a = i * n + j;
      square.triangles.push_back({{a, a + n, a + 1}});
      square.triangles.push_back({{a + 1, a + n, a + n + 1}});
    }
  }
  std::vector<std::uint32_t> one_patch(square.triangles.size(), 0);
  std::vector<VertexRole> none(square.positions.size(), VertexRole::kNone);
  auto result = run({square.view(), one_patch, none});
  ASSERT_TRUE(result.is_ok()) << result.status().to_string();
  EXPECT_EQ(result->mesh.positions.size(), 4u);
  EXPECT_EQ(result->mesh.triangles.size(), 2u);
  for (const auto& p : result->mesh.positions) {
    EXPECT_TRUE((p.x == 0 || p.x == n - 1) && (p.y == 0 || p.y == n - 1)) << p.x << "," << p.y;
  }
}

TEST_P(Meshers, RejectsMismatchedInputs) {
  Mesh sphere = uv_sphere(8, 8);
  std::vector<std::uint32_t> too_short(3, 0);
  std::vector<VertexRole> roles(sphere.positions.size(), VertexRole::kNone);
  auto result = run({sphere.view(), too_short, roles});
  ASSERT_FALSE(result.is_ok());
  EXPECT_EQ(result.status().code(), format::Code::kProcessing);
}

TEST_P(Meshers, DegenerateAndNonManifoldFacesAreSkippedNotFatal) {
  Mesh sphere = uv_sphere(12, 16);
  sphere.triangles.push_back({{1, 1, 2}});          // repeated index
  sphere.triangles.push_back(sphere.triangles[5]);  // duplicate: third face on two edges
  Labelled labels = octant_labels(sphere);
  auto result = run({sphere.view(), labels.face_patch, labels.role});
  ASSERT_TRUE(result.is_ok()) << result.status().to_string();
  EXPECT_EQ(result->skipped_input_faces, 2u);
  EXPECT_EQ(topology(result->mesh).non_manifold_edges, 0u);
}

INSTANTIATE_TEST_SUITE_P(PatchMesher, Meshers, ::testing::Values("collapse", "polygon"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace gaussmesh::stream
