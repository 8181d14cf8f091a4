#include "stream/attributes/seams.h"

#include <algorithm>
#include <array>
#include <bit>
#include <limits>
#include <unordered_map>

#include "stream/analysis/mesh_distance.h"
#include "stream/core/canonical_order.h"
#include "stream/core/fan_split.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// A vertex's values as words compared bit for bit (ordered_bits: -0 is 0): normals, colour,
// texture coordinates, zero where the input has none.
using ValueWords = std::array<std::uint32_t, 9>;
ValueWords value_words(MeshView input, std::uint32_t v) {
  ValueWords w{};
  if (!input.normals.empty()) w[0] = ordered_bits(input.normals[v].x), w[1] = ordered_bits(input.normals[v].y), w[2] = ordered_bits(input.normals[v].z);
  if (!input.colors.empty()) {
    const auto& c = input.colors[v];
    w[3] = ordered_bits(c.r), w[4] = ordered_bits(c.g), w[5] = ordered_bits(c.b), w[6] = ordered_bits(c.a);
  }
  if (!input.texcoords.empty()) w[7] = ordered_bits(input.texcoords[v].u), w[8] = ordered_bits(input.texcoords[v].v);
  return w;
}

// Per corner k of each face of seams.welded: the face across its edge k → k + 1 when that edge
// is not a seam (both faces take the same wedges at its ends), else kNone.
std::vector<std::uint32_t> faces_across(const Seams& seams) {
  const auto& faces = seams.welded.triangles;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> edges;
  edges.reserve(3 * faces.size());
  for (std::uint32_t f = 0; f < faces.size(); ++f)
    for (std::uint32_t k = 0; k < 3; ++k) {
      const std::uint32_t a = faces[f].v[k], b = faces[f].v[(k + 1) % 3];
      edges.push_back({(std::uint64_t(std::min(a, b)) << 32) | std::max(a, b), 3 * f + k});
    }
  std::sort(edges.begin(), edges.end());
  std::vector<std::uint32_t> across(3 * faces.size(), kNone);
  auto wedge_at = [&](std::uint32_t corner, std::uint32_t vertex) {
    const std::uint32_t f = corner / 3;
    for (std::uint32_t k = 0; k < 3; ++k)
      if (faces[f].v[k] == vertex) return seams.corner_wedges[3 * std::size_t(f) + k];
    return kNone;
  };
  // Each run of one edge: crossed only between exactly two faces (a border or three or more faces
  // is not crossed).
  for (std::size_t i = 0, j = 0; i < edges.size(); i = j) {
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    if (j - i != 2) continue;
    const std::uint32_t c = edges[i].second, d = edges[i + 1].second;
    const auto a = std::uint32_t(edges[i].first >> 32), b = std::uint32_t(edges[i].first);
    if (wedge_at(c, a) != wedge_at(d, a) || wedge_at(c, b) != wedge_at(d, b)) continue;  // a seam
    across[c] = d / 3;
    across[d] = c / 3;
  }
  return across;
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
    for (std::size_t v = 0; v < n; ++v) hashes[v] = position_hash(input.positions[v]);
    std::sort(hashes.begin(), hashes.end());
    if (std::adjacent_find(hashes.begin(), hashes.end()) == hashes.end()) return std::nullopt;
  }
  // Each input vertex's position and wedge, for the vertices the faces use, both numbered in the
  // order of their first vertex: the used vertices sorted by position bits (then id), and within
  // one position by their values, give each vertex the first vertex of its position and of its
  // wedge.
  std::vector<std::uint8_t> used(n, 0);
  for (const Triangle& t : input.triangles)
    for (const auto v : t.v) used[v] = 1;
  struct Placed {
    std::array<std::uint32_t, 3> bits;
    std::uint32_t v;
    bool operator<(const Placed& o) const { return bits != o.bits ? bits < o.bits : v < o.v; }
  };
  std::vector<Placed> placed;
  for (std::uint32_t v = 0; v < n; ++v)
    if (used[v]) {
      const Vec3f& p = input.positions[v];
      placed.push_back({{ordered_bits(p.x), ordered_bits(p.y), ordered_bits(p.z)}, v});
    }
  std::sort(placed.begin(), placed.end());
  std::vector<std::uint32_t> position_first(n, kNone), wedge_first(n, kNone);
  std::vector<std::pair<ValueWords, std::uint32_t>> group;
  for (std::size_t i = 0, j = 0; i < placed.size(); i = j) {
    while (j < placed.size() && placed[j].bits == placed[i].bits) ++j;
    if (j - i == 1) {
      position_first[placed[i].v] = wedge_first[placed[i].v] = placed[i].v;
      continue;
    }
    group.clear();
    for (std::size_t k = i; k < j; ++k) {
      position_first[placed[k].v] = placed[i].v;
      group.push_back({value_words(input, placed[k].v), placed[k].v});
    }
    std::sort(group.begin(), group.end());
    for (std::size_t a = 0, b = 0; a < group.size(); a = b) {
      while (b < group.size() && group[b].first == group[a].first) ++b;
      for (std::size_t k = a; k < b; ++k) wedge_first[group[k].second] = group[a].second;
    }
  }
  // Numbers in vertex order: a first vertex opens its position or wedge.
  Seams s;
  std::vector<std::uint32_t> by_position(n, kNone), wedge(n, kNone);
  std::vector<std::uint32_t> wedge_count, first_vertex;  // per position: its wedges, its first vertex
  std::uint32_t wedges = 0;
  for (std::uint32_t v = 0; v < n; ++v) {
    if (!used[v]) continue;
    if (position_first[v] == v) {
      by_position[v] = std::uint32_t(first_vertex.size());
      first_vertex.push_back(v);
      wedge_count.push_back(0);
    } else {
      by_position[v] = by_position[position_first[v]];
    }
    if (wedge_first[v] == v) {
      wedge[v] = wedges++;
      s.wedge_vertex.push_back(v);
      ++wedge_count[by_position[v]];
    } else {
      wedge[v] = wedge[wedge_first[v]];
    }
  }
  for (const auto c : wedge_count) s.seam_vertices += c > 1;
  if (s.seam_vertices == 0) return std::nullopt;
  // The welded mesh: faces with a repeated corner once welded are left out, and the positions
  // they alone used with them.
  std::vector<std::uint32_t> index(first_vertex.size(), kNone);
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
  // The regions' faces need not cover the place a vertex moved to (a region is the input around
  // the vertices it absorbed, and the place is a minimiser): from the region's nearest face, the
  // search walks to nearer faces across edges that are not seams, so it finds the face under the
  // vertex on its own side of every seam.
  std::vector<std::uint32_t> across = faces_across(seams);
  for (std::uint32_t v = 0; v < n; ++v) {
    if (!moved[v] || nearest[v].second == kNone) continue;
    const Vec3d p = to_d(welded_output.positions[v]);
    for (std::size_t step = 0; step < welded.triangles.size(); ++step) {
      const std::uint32_t f = nearest[v].second;
      std::pair<double, std::uint32_t> best = nearest[v];
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t g = across[3 * std::size_t(f) + std::size_t(k)];
        if (g == kNone) continue;
        const Triangle& t = welded.triangles[g];
        const double d = point_triangle_distance_squared(p, to_d(welded.positions[t.v[0]]), to_d(welded.positions[t.v[1]]),
                                                         to_d(welded.positions[t.v[2]]));
        if (d < best.first || (d == best.first && g < best.second)) best = {d, g};
      }
      if (best.second == f || !(best.first < nearest[v].first)) break;
      nearest[v] = best;
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
