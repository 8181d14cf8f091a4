// The stitch's first step (stream/chunk_pieces.h): patch pieces found per chunk and joined over
// border-edge records give exactly the sampler's patches before the merge — the same count, the
// same lowest face, size and label for each, and the same shared feature-edge counts — on every
// fixture cut into hundreds of chunks; a damaged record is refused.
#include "stream/chunk_pieces.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <tuple>

#include "stream/chunk_sampler.h"
#include "stream/mesh.h"
#include "stream/patch_filters.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

struct InCore {
  std::vector<StitchedPatch> patches;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint64_t> adjacency;
  // Candidate vertex -> sorted (patch, next patch, entering break) of its star.
  std::map<std::uint32_t, std::vector<std::tuple<std::uint32_t, std::uint32_t, bool>>> stars;
};

InCore in_core_patches(const Mesh& mesh, const GaussSphere& gauss, const SamplerOptions& options) {
  const MeshAdjacency adj = build_mesh_adjacency(mesh.view()).value();
  const FaceNormals normals = compute_face_normals(mesh.view(), adj, options.smooth_iterations);
  const auto labels = compute_face_labels(normals, gauss);
  const auto feature = compute_feature_edges(adj, labels);
  const Patches p = find_patches(adj, labels, feature);
  InCore out;
  out.patches.resize(p.patch_label.size());
  for (std::size_t k = 0; k < p.patch_label.size(); ++k) out.patches[k] = {~std::uint64_t{0}, 0, p.patch_label[k]};
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    StitchedPatch& s = out.patches[p.face_patch[f]];
    s.min_face = std::min<std::uint64_t>(s.min_face, f);
    ++s.faces;
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = adj.edge_neighbor[3 * f + i];
      if (g == MeshAdjacency::kNoFace || !(feature[f] >> i & 1) || g < f) continue;
      const std::uint32_t a = p.face_patch[f], b = p.face_patch[g];
      ++out.adjacency[{std::min(a, b), std::max(a, b)}];
    }
  }
  std::vector<VertexRecord> records;
  evaluate_vertices(mesh.view(), adj, normals, labels, feature, gauss, false, 0,
                    static_cast<std::uint32_t>(mesh.positions.size()), records);
  for (const VertexRecord& r : records) {
    if (!r.is_candidate) continue;
    auto& star = out.stars[r.vertex];
    for (std::uint32_t k = adj.star_begin(r.vertex); k < adj.star_end(r.vertex); ++k) {
      const std::uint32_t f = adj.vertex_corners[k] / 3, i = adj.vertex_corners[k] % 3;
      const std::uint32_t g = adj.edge_neighbor[3 * f + i];
      star.emplace_back(p.face_patch[f], g == MeshAdjacency::kNoFace ? 0xFFFFFFFFu : p.face_patch[g],
                        adj.edge_neighbor[3 * f + (i + 2) % 3] == MeshAdjacency::kNoFace);
    }
    std::sort(star.begin(), star.end());
  }
  return out;
}

void expect_stitch_equals_in_core(const std::string& path, std::uint32_t smooth, std::uint64_t chunk_faces) {
  SCOPED_TRACE(path + " smooth " + std::to_string(smooth) + " chunk faces " + std::to_string(chunk_faces));
  testing::ScratchDir tmp;
  auto mesh = load_mesh(path);
  ASSERT_TRUE(mesh.is_ok());
  GaussSphereOptions g;
  g.frequency = 4;
  auto gauss = GaussSphere::create(g);
  ASSERT_TRUE(gauss.is_ok());
  SamplerOptions options;
  options.smooth_iterations = smooth;
  PartitionOptions partition;
  partition.rings = required_overlap_rings(smooth);
  partition.max_chunk_faces = chunk_faces;
  partition.memory_bytes = std::uint64_t{64} << 20;
  partition.tmp_dir = tmp.path().string();
  auto parts = partition_mesh(path, {}, partition);
  ASSERT_TRUE(parts.is_ok()) << parts.status().to_string();
  std::vector<ChunkPieces> chunks(parts->chunks.size());
  ChunkSamplerWorkspace ws;
  for (std::size_t c = 0; c < parts->chunks.size(); ++c) {
    auto chunk = load_chunk(parts->chunks[c]);
    ASSERT_TRUE(chunk.is_ok());
    std::vector<GlobalSample> samples;
    ChunkSamplingStats stats;
    ASSERT_TRUE(sample_chunk(*chunk, *gauss, options, ws, samples, stats).is_ok());
    find_chunk_pieces(*chunk, ws.adjacency, ws.labels, ws.feature, chunks[c]);
  }
  std::size_t border = 0;
  for (const auto& c : chunks) border += c.border.size();
  EXPECT_GT(border, 0u) << "no border edge: the chunking did not cut any patch";
  auto stitched = stitch_pieces(chunks);
  ASSERT_TRUE(stitched.is_ok()) << stitched.status().to_string();
  const InCore want = in_core_patches(*mesh, *gauss, options);
  ASSERT_EQ(stitched->patches.size(), want.patches.size());
  for (std::size_t k = 0; k < want.patches.size(); ++k) {
    EXPECT_EQ(stitched->patches[k].min_face, want.patches[k].min_face) << "patch " << k;
    EXPECT_EQ(stitched->patches[k].faces, want.patches[k].faces) << "patch " << k;
    EXPECT_EQ(stitched->patches[k].label, want.patches[k].label) << "patch " << k;
  }
  ASSERT_EQ(stitched->adjacency.size(), want.adjacency.size());
  std::size_t k = 0;
  for (const auto& [pq, edges] : want.adjacency) {
    const auto& got = stitched->adjacency[k++];
    EXPECT_EQ(got.p, pq.first);
    EXPECT_EQ(got.q, pq.second);
    EXPECT_EQ(got.edges, edges) << pq.first << "-" << pq.second;
  }
  // Candidates and their stars in patch ids; recounting the feature edges from the stars (as
  // the stitch will after merges) gives >= 3 for every one.
  ASSERT_EQ(stitched->candidates.size(), want.stars.size());
  auto it = want.stars.begin();
  for (const auto& c : stitched->candidates) {
    ASSERT_EQ(c.vertex, it->first);
    std::vector<std::tuple<std::uint32_t, std::uint32_t, bool>> star;
    std::uint32_t feature_edges = 0;
    for (std::uint32_t k = c.first; k < c.first + c.count; ++k) {
      const auto& e = stitched->star[k];
      star.emplace_back(e.patch, e.next_patch, e.entering_break);
      feature_edges += (e.next_patch == 0xFFFFFFFFu || e.next_patch != e.patch) + e.entering_break;
    }
    std::sort(star.begin(), star.end());
    EXPECT_EQ(star, it->second) << "vertex " << c.vertex;
    EXPECT_GE(feature_edges, 3u) << "vertex " << c.vertex;
    ++it;
  }

  // Step 3: the merge on the stitched graph ends where the in-core sampler's merge ends.
  const PatchMergeResult merged = merge_stitched_patches(*stitched);
  auto sampled = sample_mesh(mesh->view(), *gauss, options);
  ASSERT_TRUE(sampled.is_ok());
  EXPECT_EQ(merged.merged_patches, sampled->stats.merged_patches);
  EXPECT_EQ(merged.rounds, sampled->stats.merge_rounds);
  ASSERT_EQ(merged.patch_label.size(), sampled->patch_count);
  EXPECT_EQ(merged.patch_label, sampled->patch_label);
  for (std::size_t k = 0; k < stitched->patches.size(); ++k) {
    EXPECT_EQ(merged.patch_of[k], sampled->face_patch[stitched->patches[k].min_face]) << "patch " << k;
  }
  std::vector<std::uint32_t> survivors, want_candidates;
  for (std::size_t k = 0; k < stitched->candidates.size(); ++k)
    if (merged.is_candidate[k]) survivors.push_back(stitched->candidates[k].vertex);
  for (const VertexRecord& r : sampled->candidates) want_candidates.push_back(r.vertex);
  EXPECT_EQ(survivors, want_candidates);
  EXPECT_EQ(merged.adjacency, sampled->patch_adjacency);
  std::printf("%s: %zu patches -> %zu after %zu merge rounds\n", path.c_str(), stitched->patches.size(),
              merged.patch_label.size(), merged.rounds);
}

TEST(ChunkPieces, StitchedPatchesEqualTheInCorePatchesOnEveryFixture) {
  for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "mushroom.off",
                           "bunny-lowres.ply"}) {
    expect_stitch_equals_in_core(testing::fixture(std::string("real/") + name), 0, 32);
  }
  expect_stitch_equals_in_core(testing::fixture("real/cow.off"), 2, 64);
}

TEST(ChunkPieces, DamagedRecordsAreRefused) {
  std::vector<ChunkPieces> chunks(2);
  chunks[0].pieces = {{PieceId{0} << 32, 5, 3, 0}};
  chunks[1].pieces = {{PieceId{1} << 32, 7, 2, 3}};
  // One side of an edge only.
  chunks[0].border = {{0, 3, PieceId{0} << 32, false}};
  EXPECT_EQ(stitch_pieces(chunks).status().code(), format::Code::kBadInput);
  // Both sides, but a non-feature edge between two labels.
  chunks[0].border = {{0, 3, PieceId{0} << 32, false}};
  chunks[1].border = {{3, 0, PieceId{1} << 32, false}};
  EXPECT_EQ(stitch_pieces(chunks).status().code(), format::Code::kBadInput);
  // Sides that disagree on the feature bit.
  chunks[0].border = {{0, 3, PieceId{0} << 32, true}};
  chunks[1].border = {{3, 0, PieceId{1} << 32, false}};
  EXPECT_EQ(stitch_pieces(chunks).status().code(), format::Code::kBadInput);
  // Consistent: two patches sharing one feature edge.
  chunks[0].border = {{0, 3, PieceId{0} << 32, true}};
  chunks[1].border = {{3, 0, PieceId{1} << 32, true}};
  auto ok = stitch_pieces(chunks);
  ASSERT_TRUE(ok.is_ok()) << ok.status().to_string();
  ASSERT_EQ(ok->patches.size(), 2u);
  ASSERT_EQ(ok->adjacency.size(), 1u);
  EXPECT_EQ(ok->adjacency[0].edges, 1u);
}

}  // namespace
}  // namespace gaussmesh::stream
