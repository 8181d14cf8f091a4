#include "stream/attributes/seams.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>
#include <unordered_map>

#include "stream/analysis/mesh_distance.h"
#include "stream/core/fan_split.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// A vertex's position, or its position and values, as words compared bit for bit.
struct Key {
  std::uint32_t w[12] = {};
  int size = 0;
  void add(float f) { w[size++] = std::bit_cast<std::uint32_t>(f == 0.0f ? 0.0f : f); }  // -0 is 0
  friend bool operator==(const Key& a, const Key& b) {
    return a.size == b.size && std::memcmp(a.w, b.w, sizeof(std::uint32_t) * std::size_t(a.size)) == 0;
  }
};
struct KeyHash {
  std::size_t operator()(const Key& k) const {
    std::uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int i = 0; i < k.size; ++i) h = (h ^ k.w[i]) * 0xBF58476D1CE4E5B9ull, h ^= h >> 29;
    return std::size_t(h);
  }
};

Key position_key(const Vec3f& p) {
  Key k;
  k.add(p.x), k.add(p.y), k.add(p.z);
  return k;
}

Key value_key(MeshView input, std::uint32_t v, std::uint32_t welded) {
  Key k;
  k.w[k.size++] = welded;
  if (!input.normals.empty()) k.add(input.normals[v].x), k.add(input.normals[v].y), k.add(input.normals[v].z);
  if (!input.colors.empty()) {
    const auto& c = input.colors[v];
    k.add(c.r), k.add(c.g), k.add(c.b), k.add(c.a);
  }
  if (!input.texcoords.empty()) k.add(input.texcoords[v].u), k.add(input.texcoords[v].v);
  return k;
}

}  // namespace

std::optional<Seams> find_seams(MeshView input) {
  const bool values = !input.normals.empty() || !input.colors.empty() || !input.texcoords.empty();
  if (!values || input.triangles.empty()) return std::nullopt;
  const std::size_t n = input.positions.size();
  // Most inputs have no two vertices at one place: a sort of position hashes says so without the
  // tables below.
  {
    std::vector<std::uint64_t> hashes(n);
    for (std::size_t v = 0; v < n; ++v) hashes[v] = KeyHash()(position_key(input.positions[v]));
    std::sort(hashes.begin(), hashes.end());
    if (std::adjacent_find(hashes.begin(), hashes.end()) == hashes.end()) return std::nullopt;
  }
  // Each input vertex's position and wedge, for the vertices the faces use.
  std::vector<std::uint32_t> by_position(n, kNone), wedge(n, kNone);
  std::unordered_map<Key, std::uint32_t, KeyHash> positions, wedges;
  std::vector<std::uint8_t> used(n, 0);
  for (const Triangle& t : input.triangles)
    for (const auto v : t.v) used[v] = 1;
  Seams s;
  std::vector<std::uint32_t> wedge_count;
  for (std::uint32_t v = 0; v < n; ++v) {
    if (!used[v]) continue;
    auto [p, added] = positions.try_emplace(position_key(input.positions[v]), std::uint32_t(positions.size()));
    by_position[v] = p->second;
    if (added) wedge_count.push_back(0);
    auto [w, new_wedge] = wedges.try_emplace(value_key(input, v, p->second), std::uint32_t(wedges.size()));
    wedge[v] = w->second;
    if (new_wedge) {
      s.wedge_vertex.push_back(v);
      ++wedge_count[p->second];
    }
  }
  for (const auto c : wedge_count) s.seam_vertices += c > 1;
  if (s.seam_vertices == 0) return std::nullopt;
  // The welded mesh: faces with a repeated corner once welded are left out, and the positions
  // they alone used with them.
  std::vector<std::uint32_t> index(positions.size(), kNone);
  std::vector<std::uint32_t> first_vertex(positions.size(), kNone);
  for (std::uint32_t v = 0; v < n; ++v)
    if (used[v] && first_vertex[by_position[v]] == kNone) first_vertex[by_position[v]] = v;
  std::vector<Triangle> kept;
  for (const Triangle& t : input.triangles) {
    const std::uint32_t a = by_position[t.v[0]], b = by_position[t.v[1]], c = by_position[t.v[2]];
    if (a == b || b == c || a == c) continue;
    kept.push_back(t);
    for (const auto p : {a, b, c}) index[p] = 0;
  }
  // Numbered in input order of their first vertex.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> order;
  for (std::uint32_t p = 0; p < index.size(); ++p)
    if (index[p] != kNone) order.push_back({first_vertex[p], p});
  std::sort(order.begin(), order.end());
  for (const auto& [v, p] : order) {
    index[p] = std::uint32_t(s.welded.positions.size());
    s.welded.positions.push_back(input.positions[v]);
  }
  s.welded.triangles.reserve(kept.size());
  s.corner_wedges.reserve(3 * kept.size());
  for (const Triangle& t : kept) {
    s.welded.triangles.push_back({{index[by_position[t.v[0]]], index[by_position[t.v[1]]], index[by_position[t.v[2]]]}});
    for (const auto v : t.v) s.corner_wedges.push_back(wedge[v]);
  }
  return s;
}

Mesh split_at_seams(MeshView input, const Seams& seams, const Mesh& welded_output,
                    const std::vector<std::uint32_t>& corner_wedges, const std::vector<std::uint32_t>& source,
                    const std::vector<std::uint32_t>& region, NormalsMode normals) {
  const format::AttributeKinds kinds{!input.normals.empty(), !input.colors.empty(), !input.texcoords.empty()};
  const std::size_t n = welded_output.positions.size();
  // Moved vertices take the nearest point of the input faces at the vertices they absorbed.
  std::vector<std::uint8_t> moved(n, 0);
  for (std::uint32_t v = 0; v < n; ++v)
    moved[v] = !(welded_output.positions[v] == seams.welded.positions[source[v]]);
  std::vector<std::pair<double, std::uint32_t>> nearest(n, {std::numeric_limits<double>::infinity(), kNone});
  const MeshView welded = seams.welded.view();
  for (std::uint32_t f = 0; f < welded.triangles.size(); ++f) {
    const Triangle& t = welded.triangles[f];
    const Vec3d a = to_d(welded.positions[t.v[0]]), b = to_d(welded.positions[t.v[1]]), c = to_d(welded.positions[t.v[2]]);
    std::uint32_t seen[3] = {kNone, kNone, kNone};
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = region[t.v[k]];
      if (v == kNone || !moved[v] || v == seen[0] || v == seen[1]) continue;
      seen[k] = v;
      const double d = point_triangle_distance_squared(to_d(welded_output.positions[v]), a, b, c);
      if (d < nearest[v].first) nearest[v] = {d, f};
    }
  }
  // A vertex per (output vertex, wedge) in the order the faces use them.
  std::unordered_map<std::uint64_t, std::uint32_t> split;
  Mesh out;
  std::vector<format::VertexAttributes> values;
  out.triangles.reserve(welded_output.triangles.size());
  for (std::size_t f = 0; f < welded_output.triangles.size(); ++f) {
    Triangle t;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = welded_output.triangles[f].v[k], w = corner_wedges[3 * f + std::size_t(k)];
      auto [at, added] = split.try_emplace((std::uint64_t(v) << 32) | w, std::uint32_t(out.positions.size()));
      t.v[k] = at->second;
      if (!added) continue;
      out.positions.push_back(welded_output.positions[v]);
      if (!moved[v] || nearest[v].second == kNone) {
        const std::uint32_t i = seams.wedge_vertex[w];
        format::VertexAttributes a;
        if (kinds.normals) a.normal = input.normals[i];
        if (kinds.colors) a.color = input.colors[i];
        if (kinds.texcoords) a.texcoord = input.texcoords[i];
        values.push_back(a);
      } else {
        // The face's corners as input vertices with its corners' values.
        Triangle corners;
        for (int j = 0; j < 3; ++j) corners.v[j] = seams.wedge_vertex[seams.corner_wedges[3 * std::size_t(nearest[v].second) + std::size_t(j)]];
        values.push_back(values_at(input, corners, welded_output.positions[v], kinds));
      }
    }
    out.triangles.push_back(t);
  }
  assign_attributes(values, kinds, normals, out);
  // A wedge can meet a vertex in two fans apart (the same values on both sides of another
  // chart): each fan gets its own copy, so that the output is a manifold as indexed too.
  (void)split_vertex_fans(out);
  return out;
}

}  // namespace gaussmesh::stream
