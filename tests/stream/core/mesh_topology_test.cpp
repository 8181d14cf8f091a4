// Tests for stream/core/mesh_topology: tiny meshes built in code, real fixtures, and a randomized
// comparison against a map-based reference.
#include "stream/core/mesh_topology.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "stream/core/mesh.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

using format::Triangle;
using format::Vec3f;

MeshTopology analyse(const Mesh& mesh) {
  auto result = compute_topology(mesh.view());
  EXPECT_TRUE(result.is_ok()) << result.status().to_string();
  return result.is_ok() ? result.value() : MeshTopology{};
}

// χ = 2C − 2g − b must hold whenever a genus is reported.
void expect_consistent(const MeshTopology& t) {
  if (t.genus) {
    EXPECT_EQ(t.euler_characteristic,
              2 * static_cast<long long>(t.components) - 2 * *t.genus -
                  static_cast<long long>(t.boundary_loops));
  }
}

Mesh tetrahedron(float shift = 0) {
  Mesh m;
  m.positions = {{shift, 0, 0}, {shift + 1, 0, 0}, {shift, 1, 0}, {shift, 0, 1}};
  m.triangles = {{{0, 2, 1}}, {{0, 1, 3}}, {{0, 3, 2}}, {{1, 2, 3}}};
  return m;
}

void append(Mesh& to, const Mesh& from) {
  auto base = static_cast<format::VertexIndex>(to.positions.size());
  to.positions.insert(to.positions.end(), from.positions.begin(), from.positions.end());
  for (Triangle t : from.triangles) to.triangles.push_back({{t.v[0] + base, t.v[1] + base, t.v[2] + base}});
}

// An n x m quad grid on a torus (every quad split in two): closed, genus 1.
Mesh torus_grid(int n, int m) {
  Mesh mesh;
  const float kPi = 3.14159265f;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      float u = 2 * kPi * i / n, v = 2 * kPi * j / m;
      mesh.positions.push_back({(2 + std::cos(v)) * std::cos(u), (2 + std::cos(v)) * std::sin(u), std::sin(v)});
    }
  }
  auto id = [&](int i, int j) { return static_cast<format::VertexIndex>((i % n) * m + (j % m)); };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      mesh.triangles.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      mesh.triangles.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  }
  return mesh;
}

// Unit cube, 12 outward triangles; drop_top removes the two triangles of the z = 1 face.
Mesh cube(bool drop_top) {
  Mesh m;
  for (int i = 0; i < 8; ++i) m.positions.push_back({float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)});
  std::vector<std::array<format::VertexIndex, 4>> quads = {
      {0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (std::size_t q = 0; q < quads.size(); ++q) {
    if (drop_top && q == 1) continue;
    auto [a, b, c, d] = quads[q];
    m.triangles.push_back({{a, b, c}});
    m.triangles.push_back({{a, c, d}});
  }
  return m;
}

TEST(MeshTopology, TetrahedronIsClosedGenusZero) {
  MeshTopology t = analyse(tetrahedron());
  EXPECT_EQ(t.vertices, 4u);
  EXPECT_EQ(t.faces, 4u);
  EXPECT_EQ(t.edges, 6u);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.boundary_loops, 0u);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_TRUE(t.is_manifold());
  EXPECT_TRUE(t.consistently_oriented);
  EXPECT_EQ(t.orientable, std::optional<bool>(true));
  EXPECT_EQ(t.genus, std::optional<long long>(0));
  EXPECT_FLOAT_EQ(t.bounds_max.x, 1.0f);
  EXPECT_NEAR(t.diagonal, std::sqrt(3.0), 1e-12);
}

TEST(MeshTopology, TorusGridIsGenusOne) {
  MeshTopology t = analyse(torus_grid(12, 7));
  EXPECT_EQ(t.edges, 3u * 12 * 7);
  EXPECT_EQ(t.euler_characteristic, 0);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_TRUE(t.is_manifold());
  EXPECT_EQ(t.genus, std::optional<long long>(1));
  expect_consistent(t);
}

TEST(MeshTopology, SingleTriangleHasOneBoundaryLoop) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{{0, 1, 2}}};
  MeshTopology t = analyse(m);
  EXPECT_EQ(t.boundary_edges, 3u);
  EXPECT_EQ(t.boundary_loops, 1u);
  EXPECT_EQ(t.euler_characteristic, 1);
  EXPECT_EQ(t.genus, std::optional<long long>(0));
}

TEST(MeshTopology, TrianglesSharingOnlyAVertexMakeANonManifoldVertex) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  m.triangles = {{{0, 1, 2}}, {{0, 3, 4}}};
  MeshTopology t = analyse(m);
  EXPECT_EQ(t.non_manifold_vertices, 1u);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.boundary_edges, 6u);
  EXPECT_EQ(t.boundary_loops, 2u);  // one per triangle, not one figure eight
  EXPECT_EQ(t.components, 1u);      // vertex-connected
  EXPECT_FALSE(t.is_manifold());
  EXPECT_FALSE(t.genus.has_value());
}

TEST(MeshTopology, ThreeTrianglesOnOneEdgeMakeANonManifoldEdge) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  m.triangles = {{{0, 1, 2}}, {{1, 0, 3}}, {{0, 1, 4}}};
  MeshTopology t = analyse(m);
  EXPECT_EQ(t.non_manifold_edges, 1u);
  EXPECT_EQ(t.non_manifold_vertices, 2u);  // both ends of that edge
  EXPECT_EQ(t.edges, 7u);
  EXPECT_EQ(t.boundary_edges, 6u);
  EXPECT_FALSE(t.orientable.has_value());
  EXPECT_FALSE(t.genus.has_value());
}

TEST(MeshTopology, TwoComponents) {
  Mesh m = tetrahedron();
  append(m, tetrahedron(5));
  MeshTopology t = analyse(m);
  EXPECT_EQ(t.components, 2u);
  EXPECT_EQ(t.euler_characteristic, 4);
  EXPECT_EQ(t.genus, std::optional<long long>(0));
  expect_consistent(t);
}

TEST(MeshTopology, CubeWithoutAFaceHasOneBoundaryLoop) {
  MeshTopology closed = analyse(cube(false));
  EXPECT_EQ(closed.euler_characteristic, 2);
  EXPECT_EQ(closed.genus, std::optional<long long>(0));
  MeshTopology open = analyse(cube(true));
  EXPECT_EQ(open.boundary_edges, 4u);
  EXPECT_EQ(open.boundary_loops, 1u);
  EXPECT_EQ(open.euler_characteristic, 1);
  EXPECT_EQ(open.genus, std::optional<long long>(0));
  expect_consistent(open);
}

TEST(MeshTopology, TwoConesTouchingAtTheirTipsHaveOneNonManifoldVertex) {
  // Two closed pyramids sharing the apex vertex 0: every edge has two faces, but vertex 0
  // carries two umbrellas.
  Mesh m;
  m.positions = {{0, 0, 0}};
  for (float z : {1.0f, -1.0f}) {
    for (int i = 0; i < 4; ++i) m.positions.push_back({float(i == 0) - float(i == 2), float(i == 1) - float(i == 3), z});
  }
  for (format::VertexIndex base : {1u, 5u}) {
    for (format::VertexIndex i = 0; i < 4; ++i) m.triangles.push_back({{0, base + i, base + (i + 1) % 4}});
    m.triangles.push_back({{base, base + 2, base + 1}});
    m.triangles.push_back({{base, base + 3, base + 2}});
  }
  MeshTopology t = analyse(m);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.non_manifold_vertices, 1u);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_FALSE(t.genus.has_value());
}

TEST(MeshTopology, DegenerateDuplicateZeroAreaAndUnreferenced) {
  Mesh m = tetrahedron();
  m.positions.push_back({7, 7, 7});  // 4: unreferenced
  m.positions.push_back({2, 0, 0});  // 5: collinear with 0 and 1
  m.triangles.push_back({{0, 0, 1}});  // repeated index
  m.triangles.push_back({{1, 3, 0}});  // same set as {0, 1, 3}, flipped
  m.triangles.push_back({{3, 0, 1}});  // same set and orientation, rotated
  m.triangles.push_back({{0, 1, 5}});  // zero area
  MeshTopology t = analyse(m);
  EXPECT_EQ(t.unreferenced_vertices, 1u);
  EXPECT_EQ(t.degenerate_faces, 1u);
  EXPECT_EQ(t.duplicate_faces, 2u);
  EXPECT_EQ(t.zero_area_faces, 1u);
  EXPECT_GE(t.non_manifold_edges, 1u);
  // χ counts the 5 vertices of non-degenerate faces, not the unreferenced one.
  EXPECT_EQ(t.euler_characteristic, 5 - static_cast<long long>(t.edges) + 7);
}

TEST(MeshTopology, OrientationConsistencyAndOrientability) {
  Mesh flipped = tetrahedron();
  std::swap(flipped.triangles[0].v[1], flipped.triangles[0].v[2]);
  MeshTopology t = analyse(flipped);
  EXPECT_FALSE(t.consistently_oriented);
  EXPECT_EQ(t.orientable, std::optional<bool>(true));
  EXPECT_EQ(t.genus, std::optional<long long>(0));

  // Möbius strip: a band of n quads whose ends are glued with a half twist.
  const int n = 8;
  Mesh strip;
  for (int i = 0; i < n; ++i) {
    strip.positions.push_back({float(i), 0, 0});
    strip.positions.push_back({float(i), 1, 0});
  }
  auto bottom = [&](int i) { return static_cast<format::VertexIndex>(2 * (i % n)); };
  auto top = [&](int i) { return static_cast<format::VertexIndex>(2 * (i % n) + 1); };
  for (int i = 0; i + 1 < n; ++i) {
    strip.triangles.push_back({{bottom(i), bottom(i + 1), top(i + 1)}});
    strip.triangles.push_back({{bottom(i), top(i + 1), top(i)}});
  }
  strip.triangles.push_back({{bottom(n - 1), top(0), bottom(0)}});  // the twist
  strip.triangles.push_back({{bottom(n - 1), bottom(0), top(n - 1)}});
  MeshTopology m = analyse(strip);
  EXPECT_TRUE(m.is_manifold());
  EXPECT_EQ(m.orientable, std::optional<bool>(false));
  EXPECT_EQ(m.boundary_loops, 1u);  // the Möbius strip has a single boundary curve
  EXPECT_EQ(m.euler_characteristic, 0);
  EXPECT_FALSE(m.genus.has_value());
}

TEST(MeshTopology, RejectsOutOfRangeIndex) {
  Mesh m = tetrahedron();
  m.triangles.push_back({{0, 1, 4}});
  auto result = compute_topology(m.view());
  ASSERT_FALSE(result.is_ok());
  EXPECT_EQ(result.status().code(), format::Code::kProcessing);
}

TEST(MeshTopology, EmptyMesh) {
  MeshTopology t = analyse(Mesh{});
  EXPECT_EQ(t.vertices, 0u);
  EXPECT_EQ(t.components, 0u);
  EXPECT_EQ(t.euler_characteristic, 0);
}

// Reference counts with ordered maps, for random soups.
struct Reference {
  std::size_t edges = 0, boundary = 0, non_manifold = 0, duplicates = 0, components = 0;
};
Reference reference(const Mesh& m) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edge_faces;
  std::set<std::array<std::uint32_t, 3>> face_sets;
  Reference r;
  std::vector<std::uint32_t> parent(m.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x];
    return x;
  };
  std::set<std::uint32_t> used;
  for (Triangle t : m.triangles) {
    if (t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]) continue;
    std::array<std::uint32_t, 3> s = {t.v[0], t.v[1], t.v[2]};
    std::sort(s.begin(), s.end());
    if (!face_sets.insert(s).second) ++r.duplicates;
    for (int k = 0; k < 3; ++k) {
      std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3];
      ++edge_faces[{std::min(a, b), std::max(a, b)}];
      parent[find(a)] = find(b);
      used.insert(a);
    }
  }
  for (auto& [edge, count] : edge_faces) {
    ++r.edges;
    r.boundary += count == 1;
    r.non_manifold += count > 2;
  }
  for (std::uint32_t v : used) r.components += find(v) == v;
  return r;
}

TEST(MeshTopology, RandomSoupsMatchAReference) {
  const std::uint32_t seed = 20240611;
  std::mt19937 rng(seed);
  for (int round = 0; round < 50; ++round) {
    Mesh m;
    std::uint32_t nv = 3 + rng() % 40;
    for (std::uint32_t v = 0; v < nv; ++v) m.positions.push_back({float(rng() % 5), float(rng() % 5), 0});
    std::uint32_t nf = rng() % 80;
    for (std::uint32_t f = 0; f < nf; ++f) {
      format::VertexIndex a = rng() % nv, b = rng() % nv, c = rng() % nv;
      m.triangles.push_back({{a, b, c}});
    }
    MeshTopology t = analyse(m);
    Reference r = reference(m);
    SCOPED_TRACE("seed " + std::to_string(seed) + " round " + std::to_string(round));
    EXPECT_EQ(t.edges, r.edges);
    EXPECT_EQ(t.boundary_edges, r.boundary);
    EXPECT_EQ(t.non_manifold_edges, r.non_manifold);
    EXPECT_EQ(t.duplicate_faces, r.duplicates);
    EXPECT_EQ(t.components, r.components);
    expect_consistent(t);
  }
}

TEST(MeshTopology, RelabellingDoesNotChangeTheFigures) {
  const std::uint32_t seed = 7;
  std::mt19937 rng(seed);
  Mesh a = torus_grid(9, 5);
  append(a, cube(true));
  std::vector<format::VertexIndex> perm(a.positions.size());
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin(), perm.end(), rng);
  Mesh b;
  b.positions.resize(a.positions.size());
  for (std::size_t v = 0; v < perm.size(); ++v) b.positions[perm[v]] = a.positions[v];
  for (Triangle t : a.triangles) {
    int r = rng() % 3;  // rotate the corners: same orientation
    b.triangles.push_back({{perm[t.v[r]], perm[t.v[(r + 1) % 3]], perm[t.v[(r + 2) % 3]]}});
  }
  std::shuffle(b.triangles.begin(), b.triangles.end(), rng);
  MeshTopology x = analyse(a), y = analyse(b);
  SCOPED_TRACE("seed " + std::to_string(seed));
  EXPECT_EQ(x.edges, y.edges);
  EXPECT_EQ(x.boundary_loops, y.boundary_loops);
  EXPECT_EQ(x.components, 2u);
  EXPECT_EQ(y.components, 2u);
  EXPECT_EQ(x.genus, std::optional<long long>(1));  // 1 + 0
  EXPECT_EQ(y.genus, x.genus);
  EXPECT_TRUE(y.consistently_oriented);
}

// A minimal OFF reader for the clean fixtures, so these tests do not depend on the format
// library's readers (tested on their own).
Mesh read_off_fixture(const std::string& name) {
  std::ifstream in(testing::fixture("real/" + name));
  std::string magic;
  std::size_t nv = 0, nf = 0, ne = 0;
  in >> magic >> nv >> nf >> ne;
  Mesh m;
  for (std::size_t i = 0; i < nv; ++i) {
    Vec3f p;
    in >> p.x >> p.y >> p.z;
    m.positions.push_back(p);
  }
  for (std::size_t i = 0; i < nf; ++i) {
    std::size_t k = 0;
    in >> k;
    std::vector<format::VertexIndex> poly(k);
    for (auto& v : poly) in >> v;
    for (std::size_t j = 1; j + 1 < k; ++j) m.triangles.push_back({{poly[0], poly[j], poly[j + 1]}});
  }
  EXPECT_TRUE(in) << name;
  return m;
}

TEST(MeshTopologyFixtures, CowIsClosedGenusZero) {
  MeshTopology t = analyse(read_off_fixture("cow.off"));
  EXPECT_EQ(t.vertices, 2904u);
  EXPECT_EQ(t.faces, 5804u);
  EXPECT_TRUE(t.is_closed());
  EXPECT_TRUE(t.is_manifold());
  EXPECT_EQ(t.genus, std::optional<long long>(0));
  EXPECT_EQ(t.components, 1u);
  expect_consistent(t);
}

TEST(MeshTopologyFixtures, KnotIsGenusOne) {
  MeshTopology t = analyse(read_off_fixture("knot1.off"));
  EXPECT_TRUE(t.is_closed());
  EXPECT_EQ(t.genus, std::optional<long long>(1));
  expect_consistent(t);
}

TEST(MeshTopologyFixtures, SharkHas304BoundaryEdges) {
  MeshTopology t = analyse(read_off_fixture("mech-holes-shark.off"));
  EXPECT_EQ(t.boundary_edges, 304u);
  EXPECT_TRUE(t.is_manifold());
  EXPECT_EQ(t.boundary_loops, 4u);  // χ = -2 with one component: 2g + b = 4, and g = 0
  EXPECT_EQ(t.genus, std::optional<long long>(0));
  expect_consistent(t);
}

TEST(MeshTopologyFixtures, MushroomHasOneBoundaryLoop) {
  MeshTopology t = analyse(read_off_fixture("mushroom.off"));
  EXPECT_EQ(t.boundary_loops, 1u);
  expect_consistent(t);
}

// fixtures/README.md says this scanned bunny has holes, but in this copy every edge has two
// faces (5,511 edges = 3 x 3,674 / 2, checked independently): its holes were filled.
TEST(MeshTopologyFixtures, BunnyLowresIsClosedGenusZero) {
  auto mesh = load_mesh(testing::fixture("real/bunny-lowres.ply"));
  ASSERT_TRUE(mesh.is_ok()) << mesh.status().to_string();
  MeshTopology t = analyse(mesh.value());
  EXPECT_EQ(t.vertices, 1839u);
  EXPECT_EQ(t.faces, 3674u);
  EXPECT_EQ(t.edges, 3u * t.faces / 2);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.boundary_loops, 0u);
  EXPECT_EQ(t.genus, std::optional<long long>(0));
  expect_consistent(t);
}

}  // namespace
}  // namespace gaussmesh::stream
