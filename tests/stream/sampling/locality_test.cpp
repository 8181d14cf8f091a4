// Locality contract of the sampler (docs/pipeline.md): every per-face and per-vertex decision
// is a function of a bounded neighbourhood, so a chunk holding required_overlap_rings() rings
// around the vertices it owns decides exactly as the whole mesh does. Cuts meshes into slabs
// with that overlap and compares every owned vertex's record and every star face's label.
#include <algorithm>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "stream/core/mesh_adjacency.h"
#include "stream/sampling/sampler.h"
#include "tests/support/shapes.h"

namespace gaussmesh::stream {
namespace {

struct Decisions {
  std::vector<std::uint32_t> labels;
  std::vector<VertexRecord> records;
};

Decisions decide(const Mesh& mesh, const GaussSphere& g, std::uint32_t smooth) {
  const MeshAdjacency adj = build_mesh_adjacency(mesh.view()).value();
  const FaceNormals normals = compute_face_normals(mesh.view(), adj, smooth);
  Decisions d;
  d.labels = compute_face_labels(normals, g);
  const auto feature = compute_feature_edges(adj, d.labels);
  evaluate_vertices(mesh.view(), adj, normals, d.labels, feature, g, true, 0,
                    static_cast<std::uint32_t>(mesh.positions.size()), d.records);
  return d;
}

bool same(const VertexRecord& a, const VertexRecord& b) {
  return a.gauss_vertex == b.gauss_vertex && a.characteristic == b.characteristic && a.winding == b.winding &&
         a.feature_edges == b.feature_edges && a.is_candidate == b.is_candidate && a.is_tree == b.is_tree &&
         a.is_exact_sample == b.is_exact_sample && a.enclosed == b.enclosed &&
         a.exact_gauss_vertex == b.exact_gauss_vertex && a.exact_winding == b.exact_winding &&
         a.exact_characteristic == b.exact_characteristic && a.cover_mask == b.cover_mask;
}

// Cuts mesh into `pieces` slabs along x; each chunk holds the faces within `rings` vertex rings
// of its owned vertices, renumbered. Returns the number of owned vertices checked.
std::size_t check_chunks(const Mesh& mesh, const GaussSphere& g, std::uint32_t smooth, int pieces, const std::string& name) {
  const Decisions whole = decide(mesh, g, smooth);
  const MeshAdjacency adj = build_mesh_adjacency(mesh.view()).value();
  float lo = 1e30f, hi = -1e30f;
  for (const auto& p : mesh.positions) {
    lo = std::min(lo, p.x);
    hi = std::max(hi, p.x);
  }
  const std::uint32_t rings = required_overlap_rings(smooth);
  const std::size_t nv = mesh.positions.size();
  std::size_t checked = 0;
  for (int piece = 0; piece < pieces; ++piece) {
    const float a = lo + (hi - lo) * float(piece) / float(pieces), b = lo + (hi - lo) * float(piece + 1) / float(pieces);
    std::vector<std::uint8_t> owned(nv, 0), in_ring(nv, 0);
    std::vector<std::uint32_t> frontier;
    for (std::uint32_t v = 0; v < nv; ++v) {
      const float x = mesh.positions[v].x;
      if (x >= a && (x < b || piece == pieces - 1)) {
        owned[v] = in_ring[v] = 1;
        frontier.push_back(v);
      }
    }
    // Grow rings: faces incident on the ring's vertices, then their vertices.
    std::vector<std::uint8_t> face_in(mesh.triangles.size(), 0);
    for (std::uint32_t r = 0; r < rings; ++r) {
      std::vector<std::uint32_t> next;
      for (std::uint32_t v : frontier)
        for (std::uint32_t s = adj.star_begin(v); s < adj.star_end(v); ++s) {
          const std::uint32_t f = adj.vertex_corners[s] / 3;
          if (face_in[f]) continue;
          face_in[f] = 1;
          for (std::uint32_t w : mesh.triangles[f].v)
            if (!in_ring[w]) {
              in_ring[w] = 1;
              next.push_back(w);
            }
        }
      frontier.swap(next);
    }
    // The chunk mesh, renumbered; local -> global ids.
    Mesh chunk;
    std::vector<std::uint32_t> local(nv, 0xFFFFFFFFu), global;
    std::vector<std::uint32_t> chunk_face_global;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
      if (!face_in[f]) continue;
      format::Triangle t;
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t v = mesh.triangles[f].v[i];
        if (local[v] == 0xFFFFFFFFu) {
          local[v] = static_cast<std::uint32_t>(global.size());
          global.push_back(v);
          chunk.positions.push_back(mesh.positions[v]);
        }
        t.v[i] = local[v];
      }
      chunk.triangles.push_back(t);
      chunk_face_global.push_back(static_cast<std::uint32_t>(f));
    }
    const Decisions part = decide(chunk, g, smooth);
    // Labels of the faces around owned vertices.
    for (std::size_t cf = 0; cf < chunk.triangles.size(); ++cf) {
      const auto& t = mesh.triangles[chunk_face_global[cf]];
      if (owned[t.v[0]] || owned[t.v[1]] || owned[t.v[2]]) {
        EXPECT_EQ(part.labels[cf], whole.labels[chunk_face_global[cf]]) << name << " piece " << piece;
      }
    }
    // Records of owned vertices: the same set, the same decisions.
    std::vector<VertexRecord> mine;
    for (VertexRecord r : part.records) {
      if (!owned[global[r.vertex]]) continue;
      r.vertex = global[r.vertex];
      mine.push_back(r);
    }
    std::sort(mine.begin(), mine.end(), [](const VertexRecord& x, const VertexRecord& y) { return x.vertex < y.vertex; });
    std::vector<VertexRecord> expected;
    for (const VertexRecord& r : whole.records)
      if (owned[r.vertex]) expected.push_back(r);
    EXPECT_EQ(mine.size(), expected.size()) << name << " piece " << piece;
    if (mine.size() != expected.size()) continue;
    for (std::size_t k = 0; k < mine.size(); ++k) {
      EXPECT_EQ(mine[k].vertex, expected[k].vertex) << name << " piece " << piece;
      EXPECT_TRUE(same(mine[k], expected[k])) << name << " piece " << piece << " vertex " << mine[k].vertex;
    }
    checked += expected.size();
  }
  return checked;
}

TEST(Locality, ChunksWithTheRequiredOverlapDecideAsTheWholeMesh) {
  testing::ShapeOptions o;
  o.vertices = 8000;
  o.seed = 21;
  o.noise = 0.001;
  const Mesh torus = testing::make_torus(1, 0.4, o);
  const Mesh dented = testing::make_dented_sphere(0.4, o);
  // An open mesh: the sphere with every face above z = 0.6 removed (a hole with a boundary).
  Mesh open = testing::make_sphere(o);
  std::erase_if(open.triangles, [&](const format::Triangle& t) {
    return open.positions[t.v[0]].z > 0.6f && open.positions[t.v[1]].z > 0.6f && open.positions[t.v[2]].z > 0.6f;
  });
  for (std::uint64_t seed : {1u, 2u}) {
    GaussSphereOptions go;
    go.frequency = 4;
    go.rotation = gauss_rotation_from_seed(seed);
    const GaussSphere g = GaussSphere::create(go).value();
    for (std::uint32_t smooth : {0u, 2u}) {
      const std::string tag = " seed " + std::to_string(seed) + " smooth " + std::to_string(smooth);
      EXPECT_GT(check_chunks(torus, g, smooth, 5, "noisy torus" + tag), 0u);
      EXPECT_GT(check_chunks(dented, g, smooth, 4, "dented sphere" + tag), 0u);
      EXPECT_GT(check_chunks(open, g, smooth, 3, "open sphere" + tag), 0u);
    }
  }
}

TEST(Locality, TooLittleOverlapIsDetected) {
  // The check above can fail: with smoothing, a chunk of only the stars of its owned vertices
  // (one ring) decides differently somewhere. Guards against a vacuous comparison.
  testing::ShapeOptions o;
  o.vertices = 8000;
  o.seed = 21;
  o.noise = 0.001;
  const Mesh torus = testing::make_torus(1, 0.4, o);
  GaussSphereOptions go;
  go.frequency = 4;
  const GaussSphere g = GaussSphere::create(go).value();
  const Decisions whole = decide(torus, g, 2);
  const MeshAdjacency adj = build_mesh_adjacency(torus.view()).value();
  // Chunk = star of vertex v only: compare v's label-dependent decisions for many v.
  std::size_t differ = 0;
  for (std::uint32_t v = 0; v < torus.positions.size(); v += 7) {
    Mesh star;
    std::vector<std::uint32_t> local(torus.positions.size(), 0xFFFFFFFFu);
    for (std::uint32_t s = adj.star_begin(v); s < adj.star_end(v); ++s) {
      format::Triangle t;
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t w = torus.triangles[adj.vertex_corners[s] / 3].v[i];
        if (local[w] == 0xFFFFFFFFu) {
          local[w] = static_cast<std::uint32_t>(star.positions.size());
          star.positions.push_back(torus.positions[w]);
        }
        t.v[i] = local[w];
      }
      star.triangles.push_back(t);
    }
    const Decisions part = decide(star, g, 2);
    const std::uint32_t f0 = adj.vertex_corners[adj.star_begin(v)] / 3;
    differ += part.labels[0] != whole.labels[f0];
  }
  EXPECT_GT(differ, 0u);
}

}  // namespace
}  // namespace gaussmesh::stream
