// Tests for stream/core/fan_split: a vertex per fan turns bow ties, fins, fans and orientation
// flips into manifolds that keep every face; a manifold is left as it is.
#include "stream/core/fan_split.h"

#include <gtest/gtest.h>

#include <vector>

#include "stream/core/mesh_topology.h"
#include "tests/support/shapes.h"

namespace gaussmesh::stream {
namespace {

using format::Triangle;
using format::Vec3f;
using testing::ShapeOptions;

MeshTopology topology(const Mesh& m) {
  auto t = compute_topology(m.view());
  EXPECT_TRUE(t.is_ok());
  return t.is_ok() ? *t : MeshTopology{};
}

FanSplit split(Mesh& m) {
  auto s = split_vertex_fans(m);
  EXPECT_TRUE(s.is_ok()) << s.status().to_string();
  return s.is_ok() ? *s : FanSplit{};
}

// The faces' corner positions, which a split must not change.
std::vector<Vec3f> corners(const Mesh& m) {
  std::vector<Vec3f> out;
  for (const Triangle& t : m.triangles)
    for (auto v : t.v) out.push_back(m.positions[v]);
  return out;
}

TEST(FanSplit, ABowTieBecomesTwoTrianglesWithAVertexEach) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}};
  m.triangles = {{{0, 1, 2}}, {{0, 3, 4}}};
  m.colors = {{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}, {1, 1, 0, 1}, {0, 1, 1, 1}};
  ASSERT_EQ(topology(m).non_manifold_vertices, 1u);
  const std::vector<Vec3f> before = corners(m);
  const FanSplit s = split(m);
  EXPECT_EQ(s.split_vertices, 1u);
  EXPECT_EQ(s.added_vertices, 1u);
  ASSERT_EQ(m.positions.size(), 6u);
  ASSERT_EQ(m.colors.size(), 6u);  // the copy carries the vertex's attributes
  EXPECT_EQ(m.colors[5].r, 1.0f);
  EXPECT_EQ(corners(m), before);
  EXPECT_TRUE(topology(m).is_manifold());
  EXPECT_EQ(topology(m).components, 2u);
}

TEST(FanSplit, AFinComesLooseAndTheSurfaceStaysClosed) {
  ShapeOptions shape;
  shape.vertices = 400;
  Mesh m = testing::make_torus(1.0, 0.35, shape);
  const Triangle t = m.triangles[0];
  m.positions.push_back({0, 0, 2});
  m.triangles.push_back({{t.v[0], t.v[1], static_cast<std::uint32_t>(m.positions.size() - 1)}});
  const MeshTopology before = topology(m);
  ASSERT_EQ(before.non_manifold_edges, 1u);
  const FanSplit s = split(m);
  EXPECT_EQ(s.added_vertices, 2u);  // the fin's two corners on the shared edge
  const MeshTopology after = topology(m);
  EXPECT_TRUE(after.is_manifold());
  EXPECT_EQ(after.components, 2u);
  EXPECT_EQ(after.boundary_loops, 1u);  // the loose fin; the torus is closed again
  EXPECT_EQ(after.faces, before.faces);
}

TEST(FanSplit, TwoFacesThatDisagreeOnAnEdgeComeApartAlongIt) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  m.triangles = {{{0, 1, 2}}, {{1, 2, 3}}};  // both run 1 -> 2
  ASSERT_FALSE(topology(m).consistently_oriented);
  const FanSplit s = split(m);
  EXPECT_EQ(s.added_vertices, 2u);  // the edge is a break, so each of its ends has two fans
  const MeshTopology t = topology(m);
  EXPECT_TRUE(t.is_manifold());
  EXPECT_TRUE(t.consistently_oriented);
  EXPECT_EQ(t.components, 2u);
}

TEST(FanSplit, AManifoldIsNotChanged) {
  ShapeOptions shape;
  shape.vertices = 400;
  Mesh m = testing::make_torus(1.0, 0.35, shape);
  const Mesh before = m;
  const FanSplit s = split(m);
  EXPECT_EQ(s.split_vertices, 0u);
  EXPECT_EQ(s.added_vertices, 0u);
  EXPECT_EQ(m.positions, before.positions);
  EXPECT_EQ(m.triangles, before.triangles);
}

}  // namespace
}  // namespace gaussmesh::stream
