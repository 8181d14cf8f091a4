// Shape approximation, first approach (paper §5): L2,1 Voronoi cells by multi-source Dijkstra
// over the vertex graph, then one output triangle per input triangle that spans three cells.
#include "stream/meshing/voronoi_mesher.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <queue>
#include <string>

namespace gaussmesh::stream {
namespace {

struct V3 {
  double x = 0, y = 0, z = 0;
};
V3 sub(const format::Vec3f& a, const format::Vec3f& b) { return {double(a.x) - b.x, double(a.y) - b.y, double(a.z) - b.z}; }
V3 cross(const V3& a, const V3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double norm(const V3& a) { return std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z); }

}  // namespace

format::Result<VoronoiMesherResult> mesh_voronoi(MeshView mesh, std::span<const std::uint32_t> samples) {
  const size_t n = mesh.positions.size();
  for (auto s : samples) {
    if (s >= n) {
      return format::Status::error(format::Code::kProcessing, "voronoi mesher",
                                   "sample " + std::to_string(s) + " is not one of " + std::to_string(n) + " vertices");
    }
  }
  // Vertex normals (area-weighted) and bounding-box diagonal.
  std::vector<V3> normal(n);
  V3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const auto& p : mesh.positions) {
    lo = {std::min(lo.x, double(p.x)), std::min(lo.y, double(p.y)), std::min(lo.z, double(p.z))};
    hi = {std::max(hi.x, double(p.x)), std::max(hi.y, double(p.y)), std::max(hi.z, double(p.z))};
  }
  double diagonal = n > 0 ? norm({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}) : 1.0;
  if (diagonal <= 0) diagonal = 1.0;
  for (const auto& t : mesh.triangles) {
    V3 c = cross(sub(mesh.positions[t.v[1]], mesh.positions[t.v[0]]), sub(mesh.positions[t.v[2]], mesh.positions[t.v[0]]));
    for (auto v : t.v) normal[v] = {normal[v].x + c.x, normal[v].y + c.y, normal[v].z + c.z};
  }
  for (auto& v : normal) {
    double l = norm(v);
    if (l > 0) v = {v.x / l, v.y / l, v.z / l};
  }
  // Vertex adjacency in CSR form from the triangles' edges.
  std::vector<std::uint32_t> offset(n + 1, 0);
  for (const auto& t : mesh.triangles) {
    for (auto v : t.v) offset[v + 1] += 2;
  }
  for (size_t i = 0; i < n; ++i) offset[i + 1] += offset[i];
  std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1), neighbour(offset[n]);
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      auto a = t.v[k], b = t.v[(k + 1) % 3], c = t.v[(k + 2) % 3];
      neighbour[fill[a]++] = b;
      neighbour[fill[a]++] = c;
    }
  }
  // Multi-source Dijkstra; ties broken by the smaller sample index for determinism.
  VoronoiMesherResult result;
  constexpr std::uint32_t kNone = ~0u;
  result.cell.assign(n, kNone);
  std::vector<double> distance(n, std::numeric_limits<double>::infinity());
  using Item = std::pair<double, std::pair<std::uint32_t, std::uint32_t>>;  // (d, (cell, vertex))
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  for (std::uint32_t i = 0; i < samples.size(); ++i) {
    distance[samples[i]] = 0;
    queue.push({0.0, {i, samples[i]}});
  }
  while (!queue.empty()) {
    auto [d, cv] = queue.top();
    queue.pop();
    auto [c, v] = cv;
    if (result.cell[v] != kNone) continue;
    result.cell[v] = c;
    for (auto k = offset[v]; k < offset[v + 1]; ++k) {
      auto w = neighbour[k];
      if (result.cell[w] != kNone) continue;
      V3 dn{normal[v].x - normal[w].x, normal[v].y - normal[w].y, normal[v].z - normal[w].z};
      double step = norm(dn) + 1e-3 * norm(sub(mesh.positions[v], mesh.positions[w])) / diagonal;
      if (d + step < distance[w]) {
        distance[w] = d + step;
        queue.push({d + step, {c, w}});
      }
    }
  }
  for (auto c : result.cell) result.unreached_vertices += c == kNone ? 1 : 0;
  // Output vertices: samples, in sample order.
  std::vector<std::uint32_t> output_index(samples.size());
  for (std::uint32_t i = 0; i < samples.size(); ++i) {
    output_index[i] = static_cast<std::uint32_t>(result.mesh.positions.size());
    result.mesh.positions.push_back(mesh.positions[samples[i]]);
    result.birth.push_back(samples[i]);
  }
  std::vector<std::array<std::uint32_t, 3>> seen;
  for (const auto& t : mesh.triangles) {
    std::uint32_t a = result.cell[t.v[0]], b = result.cell[t.v[1]], c = result.cell[t.v[2]];
    if (a == kNone || b == kNone || c == kNone || a == b || b == c || a == c) continue;
    format::Triangle out{{output_index[a], output_index[b], output_index[c]}};
    result.mesh.triangles.push_back(out);
    std::array<std::uint32_t, 3> key{a, b, c};
    std::sort(key.begin(), key.end());
    seen.push_back(key);
  }
  // Drop repeated triples (two input triangles spanning the same three cells).
  std::vector<size_t> order(seen.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t x, size_t y) { return seen[x] != seen[y] ? seen[x] < seen[y] : x < y; });
  std::vector<char> drop(seen.size(), 0);
  for (size_t i = 1; i < order.size(); ++i) {
    if (seen[order[i]] == seen[order[i - 1]]) drop[order[i]] = 1;
  }
  size_t kept = 0;
  for (size_t i = 0; i < result.mesh.triangles.size(); ++i) {
    if (drop[i]) {
      ++result.duplicate_triangles;
    } else {
      result.mesh.triangles[kept++] = result.mesh.triangles[i];
    }
  }
  result.mesh.triangles.resize(kept);
  // Samples that own a cell but appear in no triangle stay as vertices: their count is what
  // the report's output_vertices says; drop unreferenced ones so outputs have none.
  std::vector<std::uint32_t> remap(result.mesh.positions.size(), kNone);
  for (const auto& t : result.mesh.triangles) {
    for (auto v : t.v) remap[v] = 0;
  }
  Mesh compact;
  std::vector<std::uint32_t> birth;
  for (size_t i = 0; i < remap.size(); ++i) {
    if (remap[i] == kNone) continue;
    remap[i] = static_cast<std::uint32_t>(compact.positions.size());
    compact.positions.push_back(result.mesh.positions[i]);
    birth.push_back(result.birth[i]);
  }
  for (auto& t : result.mesh.triangles) {
    for (auto& v : t.v) v = remap[v];
  }
  compact.triangles = std::move(result.mesh.triangles);
  result.mesh = std::move(compact);
  result.birth = std::move(birth);
  return result;
}

}  // namespace gaussmesh::stream
