// Compact mesh adjacency for the sampler (paper §4): vertex stars by counting sort, the face
// across each edge by matching directed edges inside a star, fans by walking those links.
#include "stream/mesh_adjacency.h"

#include <string>

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::Status;
using format::Triangle;

bool is_collapsed(const Triangle& t) { return t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]; }

}  // namespace

format::Result<MeshAdjacency> build_mesh_adjacency(format::MeshView mesh) {
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.triangles.size();
  if (3 * nf >= MeshAdjacency::kNoFace || nv >= MeshAdjacency::kNoFace) {
    return Status::error(Code::kResources, "adjacency", "mesh too large for 32-bit corner ids");
  }
  MeshAdjacency adj;
  adj.vertex_offsets.assign(nv + 1, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    const Triangle& t = mesh.triangles[f];
    for (int i = 0; i < 3; ++i) {
      if (t.v[i] >= nv) {
        return Status::error(Code::kBadInput, "face " + std::to_string(f),
                             "vertex index " + std::to_string(t.v[i]) + " out of range (" +
                                 std::to_string(nv) + " vertices)");
      }
    }
    if (is_collapsed(t)) {
      ++adj.collapsed_faces;
      continue;
    }
    for (int i = 0; i < 3; ++i) ++adj.vertex_offsets[t.v[i] + 1];
  }
  for (std::size_t v = 0; v < nv; ++v) adj.vertex_offsets[v + 1] += adj.vertex_offsets[v];
  adj.vertex_corners.resize(adj.vertex_offsets[nv]);
  {
    std::vector<std::uint32_t> fill(adj.vertex_offsets.begin(), adj.vertex_offsets.end() - 1);
    for (std::size_t f = 0; f < nf; ++f) {
      const Triangle& t = mesh.triangles[f];
      if (is_collapsed(t)) continue;
      for (std::uint32_t i = 0; i < 3; ++i) adj.vertex_corners[fill[t.v[i]]++] = static_cast<std::uint32_t>(3 * f + i);
    }
  }
  adj.edge_neighbor.assign(3 * nf, MeshAdjacency::kNoFace);
  adj.slot_flags.assign(adj.vertex_corners.size(), 0);

  const auto* tris = mesh.triangles.data();
  auto next_of = [tris](std::uint32_t c) { return tris[c / 3].v[(c % 3 + 1) % 3]; };
  auto prev_of = [tris](std::uint32_t c) { return tris[c / 3].v[(c % 3 + 2) % 3]; };

  std::vector<std::uint32_t> ordered;
  std::vector<std::uint8_t> flags, used;
  for (std::size_t v = 0; v < nv; ++v) {
    const std::uint32_t begin = adj.vertex_offsets[v], end = adj.vertex_offsets[v + 1];
    // Outgoing edge (v, a) of each corner: manifold iff exactly one face of the star goes
    // v -> a and exactly one goes a -> v.
    for (std::uint32_t s = begin; s < end; ++s) {
      const std::uint32_t c = adj.vertex_corners[s];
      const std::uint32_t a = next_of(c);
      std::uint32_t out = 0, in = 0, partner = MeshAdjacency::kNoFace;
      for (std::uint32_t r = begin; r < end; ++r) {
        const std::uint32_t d = adj.vertex_corners[r];
        if (next_of(d) == a) ++out;
        if (prev_of(d) == a) {
          ++in;
          partner = d / 3;
        }
      }
      if (out == 1 && in == 1) adj.edge_neighbor[c] = partner;  // edge i of f sits at 3 f + i = c
      else ++adj.break_edges;
    }
  }
  // Fans need the links of the incoming edges too, which other vertices' passes set.
  for (std::size_t v = 0; v < nv; ++v) {
    const std::uint32_t begin = adj.vertex_offsets[v], end = adj.vertex_offsets[v + 1];
    // Fans: walk counter-clockwise (across edge (prev, v)) from each open end, then cycles.
    const std::uint32_t degree = end - begin;
    ordered.clear();
    flags.clear();
    used.assign(degree, 0);
    auto slot_of_face = [&](std::uint32_t face) {
      for (std::uint32_t r = 0; r < degree; ++r)
        if (adj.vertex_corners[begin + r] / 3 == face) return r;
      return degree;
    };
    auto walk = [&](std::uint32_t r, bool closed) {
      flags.push_back(static_cast<std::uint8_t>(MeshAdjacency::kFanStart | (closed ? MeshAdjacency::kFanClosed : 0)));
      const std::uint32_t start = r;
      while (true) {
        used[r] = 1;
        const std::uint32_t c = adj.vertex_corners[begin + r];
        ordered.push_back(c);
        const std::uint32_t next_face = adj.edge_neighbor[3 * (c / 3) + (c % 3 + 2) % 3];
        if (next_face == MeshAdjacency::kNoFace) break;
        const std::uint32_t nr = slot_of_face(next_face);
        if (nr == degree || nr == start || used[nr]) break;
        flags.push_back(0);
        r = nr;
      }
    };
    for (std::uint32_t r = 0; r < degree; ++r) {
      const std::uint32_t c = adj.vertex_corners[begin + r];
      if (adj.edge_neighbor[c] == MeshAdjacency::kNoFace) walk(r, false);
    }
    for (std::uint32_t r = 0; r < degree; ++r)
      if (!used[r]) walk(r, true);
    for (std::uint32_t r = 0; r < degree; ++r) {
      adj.vertex_corners[begin + r] = ordered[r];
      adj.slot_flags[begin + r] = flags[r];
    }
  }
  return adj;
}

}  // namespace gaussmesh::stream
