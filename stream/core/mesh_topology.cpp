// Topology statistics of a triangle mesh: edges by bucketing half-edges on their smaller
// vertex (a counting sort, then tiny per-vertex sorts), fans and boundary loops by union-find
// over face corners, orientability by union-find with parity over faces.
#include "stream/core/mesh_topology.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "stream/core/disjoint_sets.h"

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::Status;
using format::Triangle;
using format::Vec3f;

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// Union-find whose links carry a parity bit: relate(a, b, p) states flip(a) xor flip(b) = p and
// returns false when that contradicts what is already known.
class ParitySets {
 public:
  explicit ParitySets(std::size_t n) : parent_(n), parity_(n, 0) {
    for (std::size_t i = 0; i < n; ++i) parent_[i] = static_cast<std::uint32_t>(i);
  }
  bool relate(std::uint32_t a, std::uint32_t b, std::uint8_t p) {
    std::uint8_t pa = 0, pb = 0;
    std::uint32_t ra = find(a, pa), rb = find(b, pb);
    if (ra == rb) return (pa ^ pb) == p;
    parent_[ra] = rb;
    parity_[ra] = static_cast<std::uint8_t>(pa ^ pb ^ p);
    return true;
  }

 private:
  // Root of x and the parity of x relative to it; compresses the path.
  std::uint32_t find(std::uint32_t x, std::uint8_t& parity) {
    std::uint32_t root = x;
    std::uint8_t total = 0;
    while (parent_[root] != root) {
      total ^= parity_[root];
      root = parent_[root];
    }
    std::uint8_t p = total;
    for (std::uint32_t y = x; y != root;) {
      std::uint32_t next = parent_[y];
      std::uint8_t step = parity_[y];
      parent_[y] = root;
      parity_[y] = p;
      p ^= step;
      y = next;
    }
    parity = total;
    return root;
  }

  std::vector<std::uint32_t> parent_;
  std::vector<std::uint8_t> parity_;
};

bool is_degenerate(const Triangle& t) {
  return t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2];
}

bool has_zero_area(const Triangle& t, std::span<const Vec3f> positions) {
  const Vec3f& a = positions[t.v[0]];
  const Vec3f& b = positions[t.v[1]];
  const Vec3f& c = positions[t.v[2]];
  double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
  double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
  return uy * vz - uz * vy == 0 && uz * vx - ux * vz == 0 && ux * vy - uy * vx == 0;
}

void compute_bounds(std::span<const Vec3f> positions, MeshTopology& out) {
  if (positions.empty()) return;
  Vec3f lo = positions[0], hi = positions[0];
  for (const Vec3f& p : positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  out.bounds_min = lo;
  out.bounds_max = hi;
  double dx = double(hi.x) - lo.x, dy = double(hi.y) - lo.y, dz = double(hi.z) - lo.z;
  out.diagonal = std::sqrt(dx * dx + dy * dy + dz * dz);
}

// A half-edge in the bucket of its smaller vertex: the larger vertex and its id
// (face * 3 + k, running from corner k to corner k + 1 of the face).
struct BucketEntry {
  std::uint32_t hi;
  std::uint32_t half;
};

std::uint32_t corner_vertex(std::span<const Triangle> tris, std::uint32_t corner) {
  return tris[corner / 3].v[corner % 3];
}
std::uint32_t next_corner(std::uint32_t corner) {
  return corner - corner % 3 + (corner % 3 + 1) % 3;
}
std::uint32_t prev_corner(std::uint32_t corner) {
  return corner - corner % 3 + (corner % 3 + 2) % 3;
}

}  // namespace

format::Result<MeshTopology> compute_topology(format::MeshView mesh) {
  const std::span<const Vec3f> positions = mesh.positions;
  const std::span<const Triangle> tris = mesh.triangles;
  const std::size_t nv = positions.size();
  const std::size_t nf = tris.size();
  if (nf >= kNone / 3) {
    return Status::error(Code::kResources, "topology",
                         std::to_string(nf) + " faces exceed the 32-bit corner ids");
  }
  MeshTopology out;
  out.vertices = nv;
  out.faces = nf;
  compute_bounds(positions, out);

  // Referenced vertices, degenerate and zero-area faces; bucket sizes per smaller vertex.
  std::vector<std::uint8_t> used(nv, 0);  // 1: referenced, 2: on a non-degenerate face
  std::vector<std::size_t> offset(nv + 1, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    const Triangle& t = tris[f];
    if (t.v[0] >= nv || t.v[1] >= nv || t.v[2] >= nv) {
      return Status::error(Code::kProcessing, "topology",
                           "face " + std::to_string(f) + " refers to a vertex outside the mesh");
    }
    if (is_degenerate(t)) {
      ++out.degenerate_faces;
      for (auto v : t.v) used[v] = std::max<std::uint8_t>(used[v], 1);
      continue;
    }
    if (has_zero_area(t, positions)) ++out.zero_area_faces;
    for (int k = 0; k < 3; ++k) {
      used[t.v[k]] = 2;
      ++offset[std::min(t.v[k], t.v[(k + 1) % 3]) + 1];
    }
  }
  std::size_t topo_vertices = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    if (used[v] == 0) ++out.unreferenced_vertices;
    if (used[v] == 2) ++topo_vertices;
  }
  const std::size_t topo_faces = nf - out.degenerate_faces;
  for (std::size_t v = 0; v < nv; ++v) offset[v + 1] += offset[v];

  // Counting sort of half-edges into buckets, then sort each bucket by the larger vertex.
  std::vector<BucketEntry> entries(offset[nv]);
  {
    std::vector<std::size_t> fill(offset.begin(), offset.end() - 1);
    for (std::size_t f = 0; f < nf; ++f) {
      const Triangle& t = tris[f];
      if (is_degenerate(t)) continue;
      for (std::uint32_t k = 0; k < 3; ++k) {
        std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3];
        entries[fill[std::min(a, b)]++] = {std::max(a, b), static_cast<std::uint32_t>(f * 3 + k)};
      }
    }
  }
  auto by_hi = [](const BucketEntry& x, const BucketEntry& y) {
    return x.hi < y.hi || (x.hi == y.hi && x.half < y.half);
  };
  for (std::size_t v = 0; v < nv; ++v) {
    std::sort(entries.begin() + offset[v], entries.begin() + offset[v + 1], by_hi);
  }

  // One pass over the edges.
  DisjointSets vertex_sets(nv);
  DisjointSets corner_sets(nf * 3);
  ParitySets face_sets(nf);
  std::vector<std::uint8_t> non_manifold(nv, 0);
  std::vector<std::uint32_t> boundary;  // half-edge ids of boundary edges
  std::vector<std::uint32_t> thirds;    // scratch for duplicate detection
  bool orientation_conflict = false;
  for (std::size_t lo = 0; lo < nv; ++lo) {
    std::size_t run_begin = offset[lo];
    const std::size_t end = offset[lo + 1];
    while (run_begin < end) {
      const std::uint32_t hi = entries[run_begin].hi;
      std::size_t run_end = run_begin + 1;
      while (run_end < end && entries[run_end].hi == hi) ++run_end;
      const std::size_t n = run_end - run_begin;
      ++out.edges;
      vertex_sets.unite(static_cast<std::uint32_t>(lo), hi);
      if (n == 1) {
        boundary.push_back(entries[run_begin].half);
      } else if (n == 2) {
        std::uint32_t h1 = entries[run_begin].half, h2 = entries[run_begin + 1].half;
        bool same_direction = corner_vertex(tris, h1) == corner_vertex(tris, h2);
        if (same_direction) {
          out.consistently_oriented = false;
          corner_sets.unite(h1, h2);
          corner_sets.unite(next_corner(h1), next_corner(h2));
        } else {
          corner_sets.unite(h1, next_corner(h2));
          corner_sets.unite(next_corner(h1), h2);
        }
        if (!face_sets.relate(h1 / 3, h2 / 3, same_direction ? 1 : 0)) orientation_conflict = true;
      } else {
        ++out.non_manifold_edges;
        non_manifold[lo] = 1;
        non_manifold[hi] = 1;
      }
      // Duplicate faces share their (smallest, middle) edge and their largest vertex: collect
      // the largest vertex of each face for which this edge is (smallest, middle).
      if (n >= 2) {
        thirds.clear();
        for (std::size_t i = run_begin; i < run_end; ++i) {
          std::uint32_t third = corner_vertex(tris, prev_corner(entries[i].half));
          if (third > hi) thirds.push_back(third);
        }
        std::sort(thirds.begin(), thirds.end());
        for (std::size_t i = 1; i < thirds.size(); ++i) {
          if (thirds[i] == thirds[i - 1]) ++out.duplicate_faces;
        }
      }
      run_begin = run_end;
    }
  }
  out.boundary_edges = boundary.size();

  // Fans: the distinct corner roots at each vertex.
  {
    std::vector<std::uint32_t> first_fan(nv, kNone);
    for (std::size_t f = 0; f < nf; ++f) {
      if (is_degenerate(tris[f])) continue;
      for (std::uint32_t k = 0; k < 3; ++k) {
        std::uint32_t corner = static_cast<std::uint32_t>(f * 3 + k);
        std::uint32_t v = tris[f].v[k];
        std::uint32_t root = corner_sets.find(corner);
        if (first_fan[v] == kNone) {
          first_fan[v] = root;
        } else if (first_fan[v] != root) {
          non_manifold[v] = 1;
        }
      }
    }
  }
  for (std::size_t v = 0; v < nv; ++v) out.non_manifold_vertices += non_manifold[v];

  // Boundary loops: boundary edges meeting in one fan belong to one loop.
  {
    DisjointSets loop_sets(boundary.size());
    std::vector<std::uint32_t> edge_at_fan(nf * 3, kNone);
    for (std::uint32_t i = 0; i < boundary.size(); ++i) {
      for (std::uint32_t corner : {boundary[i], next_corner(boundary[i])}) {
        std::uint32_t fan = corner_sets.find(corner);
        if (edge_at_fan[fan] == kNone) {
          edge_at_fan[fan] = i;
        } else {
          loop_sets.unite(edge_at_fan[fan], i);
        }
      }
    }
    for (std::uint32_t i = 0; i < boundary.size(); ++i) {
      if (loop_sets.find(i) == i) ++out.boundary_loops;
    }
  }

  for (std::size_t v = 0; v < nv; ++v) {
    if (used[v] == 2 && vertex_sets.find(static_cast<std::uint32_t>(v)) == v) ++out.components;
  }
  out.euler_characteristic = static_cast<long long>(topo_vertices) -
                             static_cast<long long>(out.edges) +
                             static_cast<long long>(topo_faces);
  if (out.non_manifold_edges == 0) out.orientable = !orientation_conflict;
  if (out.is_manifold() && out.orientable.value_or(false)) {
    long long twice_genus = 2 * static_cast<long long>(out.components) -
                            static_cast<long long>(out.boundary_loops) - out.euler_characteristic;
    // Always even and non-negative for an orientable manifold; guard anyway.
    if (twice_genus >= 0 && twice_genus % 2 == 0) out.genus = twice_genus / 2;
  }
  return out;
}

}  // namespace gaussmesh::stream
