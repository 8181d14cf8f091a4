// Unit tests of the sampler's steps (stream/sampling/sampler.h, stream/core/mesh_adjacency.h,
// stream/sampling/patch_filters.h) on tiny meshes built in code: adjacency and fans, degenerate and
// collapsed faces, boundary and non-manifold edges, feature edges, windings, filters.
#include "stream/sampling/sampler.h"

#include <cmath>
#include <numbers>
#include <numeric>

#include <gtest/gtest.h>

#include "stream/core/mesh_adjacency.h"
#include "stream/sampling/patch_filters.h"
#include "tests/support/shapes.h"

namespace gaussmesh::stream {
namespace {

using format::Triangle;
using format::Vec3f;

GaussSphere gauss(std::uint32_t f, std::uint64_t seed = kDefaultGaussSeed) {
  GaussSphereOptions o;
  o.frequency = f;
  o.rotation = gauss_rotation_from_seed(seed);
  return GaussSphere::create(o).value();
}

Mesh octahedron() {
  Mesh m;
  m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {{{0, 2, 4}}, {{2, 1, 4}}, {{1, 3, 4}}, {{3, 0, 4}},
                 {{2, 0, 5}}, {{1, 2, 5}}, {{3, 1, 5}}, {{0, 3, 5}}};
  return m;
}

// A closed fan of n triangles around vertex 0 at heights z_k on a unit circle.
Mesh fan(const std::vector<float>& heights, float apex = 0) {
  Mesh m;
  m.positions.push_back({0, 0, apex});
  const std::size_t n = heights.size();
  for (std::size_t k = 0; k < n; ++k) {
    const double a = 2 * std::numbers::pi * double(k) / double(n);
    m.positions.push_back({float(std::cos(a)), float(std::sin(a)), heights[k]});
  }
  for (std::uint32_t k = 0; k < n; ++k)
    m.triangles.push_back({{0, 1 + k, 1 + (k + 1) % static_cast<std::uint32_t>(n)}});
  return m;
}

// Small deterministic numbers below n (a 64-bit LCG's high bits): random meshes by seed.
struct Lcg {
  std::uint64_t state;
  std::uint32_t operator()(std::uint32_t n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<std::uint32_t>((state >> 33) % n);
  }
};

// Random triangles over min_vertices + next(more_vertices) vertices, 1 + next(max_faces) of them:
// boundaries, non-manifold edges and vertices, inconsistent orientations, collapsed faces.
Mesh triangle_soup(Lcg& next, std::uint32_t min_vertices, std::uint32_t more_vertices, std::uint32_t max_faces) {
  Mesh m;
  const std::uint32_t nv = min_vertices + next(more_vertices);
  for (std::uint32_t v = 0; v < nv; ++v) m.positions.push_back({float(v), float(v * v % 7), float(v % 3)});
  const std::uint32_t nf = 1 + next(max_faces);
  for (std::uint32_t f = 0; f < nf; ++f) m.triangles.push_back({{next(nv), next(nv), next(nv)}});
  return m;
}

TEST(MeshAdjacency, ClosedMeshHasOneClosedFanPerVertexAndSymmetricNeighbours) {
  const Mesh m = octahedron();
  const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
  EXPECT_EQ(adj.break_edges, 0u);
  for (std::uint32_t v = 0; v < 6; ++v) {
    ASSERT_EQ(adj.star_end(v) - adj.star_begin(v), 4u);
    EXPECT_EQ(adj.slot_flags[adj.star_begin(v)], MeshAdjacency::kFanStart | MeshAdjacency::kFanClosed);
    for (std::uint32_t s = adj.star_begin(v) + 1; s < adj.star_end(v); ++s) EXPECT_EQ(adj.slot_flags[s], 0);
  }
  for (std::uint32_t f = 0; f < 8; ++f)
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = adj.edge_neighbor[3 * f + i];
      ASSERT_NE(g, MeshAdjacency::kNoFace);
      const auto* n = &adj.edge_neighbor[3 * g];
      EXPECT_TRUE(n[0] == f || n[1] == f || n[2] == f);
    }
}

TEST(MeshAdjacency, BoundaryNonManifoldAndBadIndices) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  // Three faces on edge (0, 1): non-manifold; every edge is a break.
  m.triangles = {{{0, 1, 2}}, {{1, 0, 3}}, {{1, 0, 4}}};
  const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
  for (std::uint32_t e : adj.edge_neighbor) EXPECT_EQ(e, MeshAdjacency::kNoFace);
  // Vertex 0 has three open fans of one face each.
  int fans = 0;
  for (std::uint32_t s = adj.star_begin(0); s < adj.star_end(0); ++s) fans += adj.slot_flags[s] & MeshAdjacency::kFanStart;
  EXPECT_EQ(fans, 3);
  m.triangles.push_back({{0, 1, 9}});
  const auto bad = build_mesh_adjacency(m.view());
  ASSERT_FALSE(bad.is_ok());
  EXPECT_EQ(bad.status().code(), format::Code::kBadInput);
  EXPECT_NE(bad.status().where().find("face 3"), std::string::npos);
}

// Vertex 0 holds one face and comes first, so its star sizes the per-thread scratch; vertex 1,
// next in the same range, is the apex of an open fan of four faces, whose walk uses every
// scratch array up to its degree: an array the first star left shorter is a heap overflow
// (reported by the sanitized stage, scripts/bootstrap sanitize).
TEST(MeshAdjacency, AnOpenFanAfterASmallerStarIsWalkedWhole) {
  Mesh m;
  m.positions = {{0, 2, 0}, {0, 0, 0}, {1, -1, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-1, 1, 0}};
  m.triangles = {{{1, 2, 3}}, {{1, 3, 4}}, {{1, 4, 5}}, {{1, 5, 6}}, {{0, 6, 5}}};
  const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
  EXPECT_EQ(adj.break_edges, 7u);  // 15 directed edges, four interior ones held twice
  ASSERT_EQ(adj.star_end(1) - adj.star_begin(1), 4u);
  // One open fan, counter-clockwise from the face whose outgoing edge (1, 2) is a boundary.
  std::vector<std::uint32_t> faces;
  for (std::uint32_t s = adj.star_begin(1); s < adj.star_end(1); ++s) {
    faces.push_back(adj.vertex_corners[s] / 3);
    EXPECT_EQ(adj.slot_flags[s], s == adj.star_begin(1) ? MeshAdjacency::kFanStart : 0) << "slot " << s;
  }
  EXPECT_EQ(faces, (std::vector<std::uint32_t>{0, 1, 2, 3}));
  EXPECT_EQ(adj.edge_neighbor[3 * 3 + 1], 4u);  // edge (5, 6) of face 3 borders vertex 0's face
}

// The sampler counts break edges from the fans (docs/sampling.md): in an open fan exactly the
// first slot's outgoing edge and the last slot's incoming edge are breaks; in a closed fan none.
// Random triangles over a few vertices give boundaries, non-manifold edges and vertices,
// inconsistent orientations and collapsed faces.
TEST(MeshAdjacency, OpenFansBeginAndEndAtTheBreakEdges) {
  const std::uint64_t seed = 7;
  Lcg next{seed};
  for (int round = 0; round < 200; ++round) {
    const Mesh m = triangle_soup(next, 4, 12, 40);
    const std::uint32_t nv = static_cast<std::uint32_t>(m.positions.size());
    const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
    for (std::uint32_t v = 0; v < nv; ++v) {
      const std::uint32_t sb = adj.star_begin(v), se = adj.star_end(v);
      for (std::uint32_t k = sb; k < se; ++k) {
        const std::uint32_t c = adj.vertex_corners[k], f = c / 3, i = c % 3;
        const std::uint8_t start_flags = [&] {
          std::uint32_t j = k;
          while (!(adj.slot_flags[j] & MeshAdjacency::kFanStart)) --j;
          return adj.slot_flags[j];
        }();
        const bool open = !(start_flags & MeshAdjacency::kFanClosed);
        const bool first = adj.slot_flags[k] & MeshAdjacency::kFanStart;
        const bool last = k + 1 == se || (adj.slot_flags[k + 1] & MeshAdjacency::kFanStart);
        EXPECT_EQ(adj.edge_neighbor[c] == MeshAdjacency::kNoFace, open && first) << "seed " << seed << " round " << round;
        EXPECT_EQ(adj.edge_neighbor[3 * f + (i + 2) % 3] == MeshAdjacency::kNoFace, open && last)
            << "seed " << seed << " round " << round;
      }
    }
  }
}

// The face across each edge against its definition, counted by brute force: edge (a, b) of a
// face is manifold iff exactly one face holds a -> b and exactly one holds b -> a (collapsed
// faces hold none). Closed fans of 3 to 30 faces, some with a face doubled or flipped, and random
// triangle soups reach every way a star is matched (up to 8 slots, up to 24, and sorted lists).
TEST(MeshAdjacency, EdgeNeighboursFollowTheDirectedEdgeCounts) {
  Lcg next{11};
  auto check = [](const Mesh& m, const std::string& what) {
    const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
    const auto& t = m.triangles;
    auto collapsed = [&](std::size_t f) { return t[f].v[0] == t[f].v[1] || t[f].v[1] == t[f].v[2] || t[f].v[0] == t[f].v[2]; };
    std::size_t breaks = 0;
    for (std::size_t f = 0; f < t.size(); ++f) {
      for (int i = 0; i < 3; ++i) {
        std::uint32_t expected = MeshAdjacency::kNoFace;
        if (!collapsed(f)) {
          const std::uint32_t a = t[f].v[i], b = t[f].v[(i + 1) % 3];
          std::uint32_t same = 0, opposite = 0, across = MeshAdjacency::kNoFace;
          for (std::size_t g = 0; g < t.size(); ++g) {
            if (collapsed(g)) continue;
            for (int j = 0; j < 3; ++j) {
              const std::uint32_t c = t[g].v[j], d = t[g].v[(j + 1) % 3];
              same += c == a && d == b;
              if (c == b && d == a) {
                ++opposite;
                across = static_cast<std::uint32_t>(g);
              }
            }
          }
          if (same == 1 && opposite == 1) expected = across;
          breaks += expected == MeshAdjacency::kNoFace;
        }
        ASSERT_EQ(adj.edge_neighbor[3 * f + i], expected) << what << ", face " << f << " edge " << i;
      }
    }
    EXPECT_EQ(adj.break_edges, breaks) << what;
  };
  for (std::uint32_t n = 3; n <= 30; ++n) {
    Mesh m = fan(std::vector<float>(n, 0.0f));
    check(m, "fan " + std::to_string(n));
    m.triangles.push_back(m.triangles[next(n)]);  // a doubled face: its three edges break
    check(m, "fan " + std::to_string(n) + " with a doubled face");
    m.triangles.pop_back();
    auto& flipped = m.triangles[next(n)];
    std::swap(flipped.v[1], flipped.v[2]);  // a face against its neighbours' orientation
    check(m, "fan " + std::to_string(n) + " with a flip");
  }
  for (int round = 0; round < 300; ++round) check(triangle_soup(next, 3, 20, 80), "soup " + std::to_string(round));
}

TEST(Sampler, BoundaryEdgesAreFeatureEdges) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  m.triangles = {{{0, 1, 2}}, {{1, 3, 2}}};
  const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
  const GaussSphere g = gauss(2);
  const auto normals = compute_face_normals(m.view(), adj, 0);
  const auto labels = compute_face_labels(normals, g);
  EXPECT_EQ(labels[0], labels[1]);
  const auto feature = compute_feature_edges(adj, labels);
  // Face 0: edges (0,1) and (2,0) are boundary, (1,2) is shared with the same label.
  EXPECT_EQ(feature[0], 0b101);
  EXPECT_EQ(feature[1], 0b011);
}

TEST(Sampler, DegenerateFaceInheritsItsNeighboursNormalAndCollapsedFaceHasNoLabel) {
  Mesh m;
  // Two triangles of a flat square with a zero-area sliver (2, 1, 4) on the diagonal (1, 2):
  // 4 is the midpoint of the diagonal.
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0.5f}, {0.5f, 0.5f, 0}};
  m.triangles = {{{0, 1, 4}}, {{0, 4, 2}}, {{1, 3, 2}}, {{1, 2, 4}}, {{0, 0, 3}}};
  const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
  EXPECT_EQ(adj.collapsed_faces, 1u);
  const auto normals = compute_face_normals(m.view(), adj, 0);
  EXPECT_TRUE(normals.degenerate[3]);
  EXPECT_TRUE(normals.degenerate[4]);
  EXPECT_EQ(normals.degenerate_count, 2u);
  // Face 3 (1,2,4) touches face 2 across (1, 2) and faces 0, 1 across (4, 1), (2, 4): its
  // normal is the area-weighted mean of theirs, a unit vector between +z and face 2's normal.
  const Vec3f n = normals.normal[3];
  EXPECT_NEAR(n.x * n.x + n.y * n.y + n.z * n.z, 1.0, 1e-6);
  EXPECT_GT(n.z, 0.5f);
  const auto labels = compute_face_labels(normals, gauss(2));
  EXPECT_NE(labels[3], kNoLabel);
  EXPECT_EQ(labels[4], kNoLabel);  // collapsed: no neighbours, no normal
}

TEST(Sampler, ConvexPolyhedronEnclosesEveryGaussianVertexExactlyOnce) {
  // On a closed convex polyhedron every direction lies in exactly one vertex's normal cone, so
  // the exact windings add up to one per Gaussian vertex even on a coarse mesh.
  for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    const GaussSphere g = gauss(3, seed);
    const Mesh m = octahedron();
    const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
    const auto normals = compute_face_normals(m.view(), adj, 0);
    const auto labels = compute_face_labels(normals, g);
    const auto feature = compute_feature_edges(adj, labels);
    std::vector<VertexRecord> records;
    evaluate_vertices(m.view(), adj, normals, labels, feature, g, true, 0, 6, records);
    std::size_t enclosed = 0;
    for (const VertexRecord& r : records) {
      enclosed += r.enclosed;
      if (r.is_exact_sample) {
        EXPECT_EQ(r.exact_winding, 1) << "seed " << seed;
        EXPECT_EQ(r.exact_characteristic, Characteristic::kConvex) << "seed " << seed;
      }
    }
    EXPECT_EQ(enclosed, g.vertex_count()) << "seed " << seed;
  }
}

TEST(Sampler, SaddleVertexWindsNegativelyAndBowlConcave) {
  // z = 0.6 cos(2θ) on the rim: a saddle whose normals sweep around the pole once, reversed.
  std::vector<float> saddle, bowl;
  for (int k = 0; k < 16; ++k) {
    saddle.push_back(0.6f * float(std::cos(2 * 2 * std::numbers::pi * k / 16)));
    bowl.push_back(0.7f);
  }
  int found[2] = {0, 0};
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const GaussSphere g = gauss(1, seed);  // coarse: the pole region holds a Gaussian vertex often
    for (int kind = 0; kind < 2; ++kind) {
      const Mesh m = fan(kind == 0 ? saddle : bowl);
      const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
      const auto normals = compute_face_normals(m.view(), adj, 0);
      const auto labels = compute_face_labels(normals, g);
      const auto feature = compute_feature_edges(adj, labels);
      std::vector<VertexRecord> records;
      evaluate_vertices(m.view(), adj, normals, labels, feature, g, true, 0, 1, records);
      for (const VertexRecord& r : records) {
        if (!r.is_exact_sample) continue;
        ++found[kind];
        if (kind == 0) {
          EXPECT_LT(r.exact_winding, 0) << "seed " << seed;
          EXPECT_EQ(r.exact_characteristic, Characteristic::kSaddle);
        } else {
          EXPECT_EQ(r.exact_winding, 1) << "seed " << seed;
          EXPECT_EQ(r.exact_characteristic, Characteristic::kConcave);
        }
      }
    }
  }
  EXPECT_GT(found[0], 0);
  EXPECT_GT(found[1], 0);
}

TEST(PatchFilters, PatchesAreLabelComponentsAcrossNonFeatureEdges) {
  const Mesh m = octahedron();
  const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
  std::vector<std::uint32_t> labels = {7, 7, 7, 7, 9, 9, 9, 9};  // top half, bottom half
  const auto feature = compute_feature_edges(adj, labels);
  const Patches p = find_patches(adj, labels, feature);
  ASSERT_EQ(p.patch_label.size(), 2u);
  EXPECT_EQ(p.patch_size[0], 4u);
  // Two patches, no candidate (equator vertices have 2 feature edges): each would merge into
  // the other, but a plan never merges both ways at once.
  std::vector<std::uint8_t> is_candidate(6, 0);
  const auto plan = plan_untriangulatable_merges(m.view(), adj, p, feature, is_candidate);
  EXPECT_EQ(plan[0], 1u);
  EXPECT_EQ(plan[1], kNoPatch);
}

TEST(PatchFilters, NoisyFilterKeepsAMinimumCoverAndDifferentCharacteristics) {
  // Four adjacent candidates of one v_G, same characteristic: masks 0b000111, 0b111000,
  // 0b001110 and 0b100001. {0, 1} covers all six triangles: 2 and 3 go.
  std::vector<NoisyFilterInput> c = {{10, 5, 1, 0b000111}, {11, 5, 1, 0b111000}, {12, 5, 1, 0b001110},
                                     {13, 5, 1, 0b100001}, {14, 5, 3, 0b000001}, {15, 6, 1, 0b1}};
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> adjacency = {{10, 11}, {11, 12}, {12, 13}, {13, 14}, {14, 15}};
  const auto keep = noisy_sample_filter(c, adjacency);
  EXPECT_EQ(keep, (std::vector<std::uint8_t>{1, 1, 0, 1, 1, 1}));  // 13: rule 1 with 14 (saddle)
}

}  // namespace
}  // namespace gaussmesh::stream
