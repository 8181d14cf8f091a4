// Tests of the Voronoi mesher (paper §5, first approach) on tiny meshes built in code.
#include "stream/meshing/voronoi_mesher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

namespace gaussmesh::stream {
namespace {

// An octahedron refined k times (midpoints pushed to the unit sphere).
Mesh refined_octahedron(int levels) {
  Mesh m;
  m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {{{0, 2, 4}}, {{2, 1, 4}}, {{1, 3, 4}}, {{3, 0, 4}}, {{2, 0, 5}}, {{1, 2, 5}}, {{3, 1, 5}}, {{0, 3, 5}}};
  for (int level = 0; level < levels; ++level) {
    std::vector<format::Triangle> next;
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoint;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      auto pa = m.positions[a], pb = m.positions[b];
      double x = pa.x + pb.x, y = pa.y + pb.y, z = pa.z + pb.z, l = std::sqrt(x * x + y * y + z * z);
      m.positions.push_back({float(x / l), float(y / l), float(z / l)});
      return midpoint[key] = std::uint32_t(m.positions.size() - 1);
    };
    for (auto t : m.triangles) {
      auto ab = mid(t.v[0], t.v[1]), bc = mid(t.v[1], t.v[2]), ca = mid(t.v[2], t.v[0]);
      next.push_back({{t.v[0], ab, ca}});
      next.push_back({{ab, t.v[1], bc}});
      next.push_back({{ca, bc, t.v[2]}});
      next.push_back({{ab, bc, ca}});
    }
    m.triangles = std::move(next);
  }
  return m;
}

TEST(VoronoiMesher, OctahedronCornersRebuildTheOctahedron) {
  Mesh sphere = refined_octahedron(4);
  std::vector<std::uint32_t> samples = {0, 1, 2, 3, 4, 5};
  auto result = mesh_voronoi(sphere.view(), samples);
  ASSERT_TRUE(result.is_ok()) << result.status().to_string();
  EXPECT_EQ(result->mesh.positions.size(), 6u);
  EXPECT_EQ(result->mesh.triangles.size(), 8u);
  EXPECT_EQ(result->unreached_vertices, 0u);
  // Every output vertex is an input vertex, unmoved.
  for (size_t i = 0; i < result->birth.size(); ++i) {
    EXPECT_EQ(result->mesh.positions[i], sphere.positions[result->birth[i]]);
  }
  // Outward orientation kept: each output face's normal points away from the origin.
  for (const auto& t : result->mesh.triangles) {
    auto a = result->mesh.positions[t.v[0]], b = result->mesh.positions[t.v[1]], c = result->mesh.positions[t.v[2]];
    double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z, vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
    double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    EXPECT_GT(nx * (a.x + b.x + c.x) + ny * (a.y + b.y + c.y) + nz * (a.z + b.z + c.z), 0.0);
  }
}

TEST(VoronoiMesher, EveryVertexJoinsTheNearestSamplesCell) {
  Mesh sphere = refined_octahedron(3);
  std::vector<std::uint32_t> samples = {0, 1, 4};
  auto result = mesh_voronoi(sphere.view(), samples);
  ASSERT_TRUE(result.is_ok());
  ASSERT_EQ(result->cell.size(), sphere.positions.size());
  for (size_t i = 0; i < samples.size(); ++i) EXPECT_EQ(result->cell[samples[i]], i);
  // Vertices near +x belong to sample 0's cell.
  for (size_t v = 0; v < sphere.positions.size(); ++v) {
    if (sphere.positions[v].x > 0.9f) {
      EXPECT_EQ(result->cell[v], 0u) << "vertex " << v;
    }
  }
}

TEST(VoronoiMesher, RejectsOutOfRangeSamples) {
  Mesh sphere = refined_octahedron(1);
  std::vector<std::uint32_t> samples = {0, 999};
  auto result = mesh_voronoi(sphere.view(), samples);
  ASSERT_FALSE(result.is_ok());
  EXPECT_EQ(result.status().code(), format::Code::kProcessing);
}

}  // namespace
}  // namespace gaussmesh::stream
