// The stitch's first step (stream/stitch/chunk_pieces.h): patch pieces found per chunk and joined over
// border-edge records give exactly the sampler's patches before the merge — the same count, the
// same lowest face, size and label for each, and the same shared feature-edge counts — on every
// fixture cut into hundreds of chunks; a damaged record is refused.
#include "stream/stitch/chunk_pieces.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <map>
#include <tuple>

#include "stream/sampling/chunk_sampler.h"
#include "stream/core/mesh.h"
#include "stream/sampling/patch_filters.h"
#include "stream/stitch/piece_joins.h"
#include "tests/support/stitch_merge.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

struct InCore {
  std::vector<StitchedPatch> patches;
  std::vector<std::uint32_t> face_patch;  // before the merge
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint64_t> adjacency;
  // Candidate vertex -> sorted (patch, next patch, entering break) of its star.
  std::map<std::uint32_t, std::vector<std::tuple<std::uint32_t, std::uint32_t, bool>>> stars;
};

InCore in_core_patches(const Mesh& mesh, const GaussSphere& gauss, const SamplerOptions& options) {
  const MeshAdjacency adj = build_mesh_adjacency(mesh.view()).value();
  const FaceNormals normals = compute_face_normals(mesh.view(), adj, options.smooth_iterations);
  const auto labels = compute_face_labels(normals, gauss);
  const auto feature = compute_feature_edges(adj, labels);
  std::vector<std::uint64_t> keys;
  face_order_keys(mesh.view(), keys);
  const Patches p = find_patches(adj, labels, feature, keys);
  InCore out;
  out.face_patch = p.face_patch;
  out.patches.resize(p.patch_label.size());
  for (std::size_t k = 0; k < p.patch_label.size(); ++k) out.patches[k] = {~std::uint64_t{0}, 0, 0, p.patch_label[k]};
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    StitchedPatch& s = out.patches[p.face_patch[f]];
    if (keys[f] < s.min_key) {  // the first face by (key, id): faces in ascending id
      s.min_key = keys[f];
      s.min_face = f;
    }
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
  const std::size_t nc = parts->chunks.size();
  std::vector<ChunkPieces> chunks(nc);
  // Border edges and answers through the files, in several buckets.
  auto joins = PieceJoinFiles::create(tmp.path().string(), nc, 7);
  ASSERT_TRUE(joins.is_ok()) << joins.status().to_string();
  ChunkSamplerWorkspace ws;
  std::size_t border = 0;
  for (std::size_t c = 0; c < nc; ++c) {
    auto chunk = load_chunk(parts->chunks[c]);
    ASSERT_TRUE(chunk.is_ok());
    std::vector<GlobalSample> samples;
    ChunkSamplingStats stats;
    ASSERT_TRUE(sample_chunk(*chunk, *gauss, options, ws, samples, stats).is_ok());
    find_chunk_pieces(*parts, *chunk, ws.adjacency, ws.labels, ws.feature, chunks[c]);
    // The sample pass hands over the sampler's candidates instead of counting every owned star again:
    // the same candidates and stars.
    std::vector<std::uint32_t> listed;
    for (const VertexRecord& r : ws.records)
      if (r.is_candidate) listed.push_back(r.vertex);
    ChunkPieces from_list;
    find_chunk_pieces(*parts, *chunk, ws.adjacency, ws.labels, ws.feature, from_list, nullptr, &listed);
    ASSERT_EQ(from_list.candidates.size(), chunks[c].candidates.size()) << "chunk " << c;
    for (std::size_t k = 0; k < from_list.candidates.size(); ++k) {
      const CandidateRecord &a = from_list.candidates[k], &b = chunks[c].candidates[k];
      EXPECT_TRUE(a.vertex == b.vertex && a.first == b.first && a.count == b.count) << "chunk " << c << " candidate " << k;
    }
    ASSERT_EQ(from_list.star.size(), chunks[c].star.size());
    for (std::size_t k = 0; k < from_list.star.size(); ++k) {
      const StarEntry &a = from_list.star[k], &b = chunks[c].star[k];
      EXPECT_TRUE(a.face == b.face && a.next == b.next && a.owner == b.owner && a.next_owner == b.next_owner &&
                  a.entering_break == b.entering_break);
    }
    EXPECT_EQ(from_list.border_faces.size(), chunks[c].border_faces.size());
    border += chunks[c].border.size();
    ASSERT_TRUE((*joins)->spill(static_cast<std::uint32_t>(c), chunks[c]).is_ok());
    EXPECT_TRUE(chunks[c].border.empty() && chunks[c].border_faces.empty());
  }
  EXPECT_GT(border, 0u) << "no border edge: the chunking did not cut any patch";
  ASSERT_TRUE((*joins)->finish().is_ok());
  EXPECT_EQ((*joins)->border_records(), border);
  auto stitched = stitch_pieces(chunks, **joins, MemoryBudget());
  ASSERT_TRUE(stitched.is_ok()) << stitched.status().to_string();
  const InCore want = in_core_patches(*mesh, *gauss, options);
  ASSERT_EQ(stitched->patches.size(), want.patches.size());
  for (std::size_t k = 0; k < want.patches.size(); ++k) {
    EXPECT_EQ(stitched->patches[k].min_face, want.patches[k].min_face) << "patch " << k;
    EXPECT_EQ(stitched->patches[k].min_key, want.patches[k].min_key) << "patch " << k;
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
      star.emplace_back(e.patch, e.next_patch, stitched->entering_break[k]);
      feature_edges += (e.next_patch == 0xFFFFFFFFu || e.next_patch != e.patch) + stitched->entering_break[k];
    }
    std::sort(star.begin(), star.end());
    EXPECT_EQ(star, it->second) << "vertex " << c.vertex;
    EXPECT_GE(feature_edges, 3u) << "vertex " << c.vertex;
    ++it;
  }

  // The faces of every chunk through their pieces (owned) or their owners' answer files (the
  // rest): the in-core patch wherever an answer exists, and an answer for every face sharing a
  // vertex with an owned face (what the loops pass needs).
  std::size_t answered = 0;
  for (std::size_t c = 0; c < nc; ++c) {
    auto chunk = load_chunk(parts->chunks[c]);
    ASSERT_TRUE(chunk.is_ok());
    std::vector<GlobalSample> samples;
    ChunkSamplingStats stats;
    ASSERT_TRUE(sample_chunk(*chunk, *gauss, options, ws, samples, stats).is_ok());
    ChunkPieces scratch;
    std::vector<std::uint32_t> piece_index;
    find_chunk_pieces(*parts, *chunk, ws.adjacency, ws.labels, ws.feature, scratch, &piece_index);
    std::vector<PieceId> face_piece;
    ASSERT_TRUE(chunk_face_pieces(*parts, *chunk, piece_index, **joins, face_piece).is_ok());
    std::vector<std::uint8_t> near(chunk->positions.size(), 0);
    for (std::size_t f = 0; f < chunk->triangles.size(); ++f)
      if (chunk->owned_face[f])
        for (std::uint32_t v : chunk->triangles[f].v) near[v] = 1;
    for (std::size_t f = 0; f < chunk->triangles.size(); ++f) {
      const auto& t = chunk->triangles[f];
      if (near[t.v[0]] || near[t.v[1]] || near[t.v[2]]) {
        ASSERT_NE(face_piece[f], kNoPiece) << "chunk " << c << " face " << chunk->global_face[f];
      }
      if (face_piece[f] == kNoPiece) continue;
      ++answered;
      EXPECT_EQ(stitched->patch_of_piece(face_piece[f]), want.face_patch[chunk->global_face[f]])
          << "chunk " << c << " face " << chunk->global_face[f];
    }
  }
  EXPECT_GE(answered, mesh->triangles.size());

  // Step 3: the merge on the stitched graph ends where the in-core sampler's merge ends.
  const PatchMergeResult merged = testing::merge_stitched_copy(*stitched);
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

// Stitches hand-made chunks: their border edges and answers go through the files as the sample pass's do.
format::Result<StitchedPatches> stitch(std::vector<ChunkPieces> chunks, std::size_t buckets = 3) {
  testing::ScratchDir tmp;
  auto joins = PieceJoinFiles::create(tmp.path().string(), chunks.size(), buckets);
  if (!joins) return joins.status();
  for (std::size_t c = 0; c < chunks.size(); ++c) GM_RETURN_IF_ERROR((*joins)->spill(static_cast<std::uint32_t>(c), chunks[c]));
  GM_RETURN_IF_ERROR((*joins)->finish());
  return stitch_pieces(chunks, **joins, MemoryBudget(64 << 20));
}

TEST(ChunkPieces, CandidateEdgesCountTheStarsFeatureEdges) {
  // take_merge_input keeps of each candidate's star only what the merge's re-evaluation reads.
  // Three candidates: a short star with a break and an open end, a star of 300 patches (past
  // a byte's reach: the wide list), and a star whose records name a face across that is not in
  // the star (damaged: the wide list too). Under several labellings the kept edges must give the
  // star's own count.
  constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  StitchedPatches stitched;
  stitched.patches.resize(400);
  for (std::uint32_t p = 0; p < 400; ++p) stitched.patches[p] = {p, 1, p % 7};
  auto add = [&](std::uint32_t vertex, const std::vector<std::uint32_t>& patch, const std::vector<std::uint32_t>& next,
                 const std::vector<std::uint8_t>& breaks) {
    stitched.candidates.push_back({vertex, static_cast<std::uint32_t>(stitched.star.size()), static_cast<std::uint32_t>(patch.size())});
    for (std::size_t k = 0; k < patch.size(); ++k) {
      stitched.star.push_back({patch[k], next[k]});
      stitched.entering_break.push_back(breaks[k]);
    }
  };
  add(10, {1, 1, 2, 3, 3, 4}, {1, 2, 3, 3, kNone, 1}, {0, 0, 1, 0, 0, 0});
  std::vector<std::uint32_t> fan(300), fan_next(300);
  for (std::uint32_t k = 0; k < 300; ++k) fan[k] = 50 + k;
  for (std::uint32_t k = 0; k < 300; ++k) fan_next[k] = fan[(k + 1) % 300];
  add(20, fan, fan_next, std::vector<std::uint8_t>(300, 0));
  add(30, {5, 6, 7}, {6, 399, 5}, {0, 0, 0});
  const StitchedPatches original = stitched;
  CandidateEdges edges;
  const PatchGraphInput input = take_merge_input(stitched, edges);
  EXPECT_TRUE(stitched.patches.empty());
  ASSERT_EQ(edges.fixed.size(), 3u);
  EXPECT_FALSE(edges.fixed[0] & CandidateEdges::kWide);
  EXPECT_TRUE(edges.fixed[1] & CandidateEdges::kWide);
  EXPECT_TRUE(edges.fixed[2] & CandidateEdges::kWide);
  const std::vector<std::function<std::uint32_t(std::uint32_t)>> labellings = {
      [](std::uint32_t p) { return p; },       [](std::uint32_t) { return 0u; },
      [](std::uint32_t p) { return p / 2; },   [](std::uint32_t p) { return p % 3; },
      [](std::uint32_t p) { return p < 52 || p == 6 ? 0u : p; }};
  for (std::size_t l = 0; l < labellings.size(); ++l) {
    const auto& label = labellings[l];
    for (std::uint32_t k = 0; k < 3; ++k) {
      const auto& c = original.candidates[k];
      std::uint32_t count = 0;
      for (std::uint32_t j = c.first; j < c.first + c.count; ++j) {
        const auto& e = original.star[j];
        count += original.entering_break[j] + (e.next_patch == kNone || label(e.patch) != label(e.next_patch));
      }
      const std::uint32_t* patches = input.candidate_patches.data() + input.candidate_offsets[k];
      EXPECT_EQ(edges.keeps_candidacy(k, patches, label), count >= 3) << "labelling " << l << ", candidate " << k;
    }
  }
}

TEST(ChunkPieces, DamagedRecordsAreRefused) {
  std::vector<ChunkPieces> chunks(2);
  chunks[0].pieces = {{PieceId{0} << 32, 5, 3, 0}};
  chunks[1].pieces = {{PieceId{1} << 32, 7, 2, 3}};
  // One side of an edge only.
  chunks[0].border = {{0, 3, PieceId{0} << 32, false}};
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kBadInput);
  // Both sides, but a non-feature edge between two labels.
  chunks[0].border = {{0, 3, PieceId{0} << 32, false}};
  chunks[1].border = {{3, 0, PieceId{1} << 32, false}};
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kBadInput);
  // Sides that disagree on the feature bit.
  chunks[0].border = {{0, 3, PieceId{0} << 32, true}};
  chunks[1].border = {{3, 0, PieceId{1} << 32, false}};
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kBadInput);
  // One side twice.
  chunks[0].border = {{0, 3, PieceId{0} << 32, true}, {0, 3, PieceId{0} << 32, true}};
  chunks[1].border = {{3, 0, PieceId{1} << 32, true}};
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kBadInput);
  // A border edge naming a piece nobody has.
  chunks[0].border = {{0, 3, PieceId{0} << 32, true}};
  chunks[1].border = {{3, 0, PieceId{9} << 32, true}};
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kBadInput);
  // Consistent: two patches sharing one feature edge.
  chunks[0].border = {{0, 3, PieceId{0} << 32, true}};
  chunks[1].border = {{3, 0, PieceId{1} << 32, true}};
  auto ok = stitch(chunks);
  ASSERT_TRUE(ok.is_ok()) << ok.status().to_string();
  ASSERT_EQ(ok->patches.size(), 2u);
  ASSERT_EQ(ok->adjacency.size(), 1u);
  EXPECT_EQ(ok->adjacency[0].edges, 1u);
  // A candidate whose star names a face its owner does not answer for.
  chunks[0].border_faces = {{0, PieceId{0} << 32}};
  chunks[1].border_faces = {{3, PieceId{1} << 32}};
  chunks[0].candidates = {{42, 0, 2}};
  chunks[0].star = {{0, 3, 0, 1, true}, {3, 0, 1, 0, false}};
  auto stars = stitch(chunks);
  ASSERT_TRUE(stars.is_ok()) << stars.status().to_string();
  ASSERT_EQ(stars->star.size(), 2u);
  EXPECT_EQ(stars->star[0].patch, 0u);
  EXPECT_EQ(stars->star[0].next_patch, 1u);
  chunks[0].star[1].face = 4;  // chunk 1 owns faces 3 only
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kBadInput);
  chunks[0].star[1] = {3, 0, 5, 0, false};  // an owner that does not exist
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kBadInput);
  chunks[0].star[1] = {3, 0, 0, 0, false};  // the wrong owner: chunk 0 does not answer for face 3
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kBadInput);
  // Candidates go to their own file beside the stars, so they must name the stars in order and
  // all of them (the file keeps counts only).
  chunks[0].star[1] = {3, 0, 1, 0, false};
  chunks[0].candidates = {{42, 0, 1}};
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kProcessing);
  chunks[0].candidates = {{42, 0, 1}, {43, 0, 1}};
  EXPECT_EQ(stitch(chunks).status().code(), format::Code::kProcessing);
  chunks[0].candidates = {{42, 0, 1}, {43, 1, 1}};
  auto two = stitch(chunks);
  ASSERT_TRUE(two.is_ok()) << two.status().to_string();
  ASSERT_EQ(two->candidates.size(), 2u);
  EXPECT_EQ(two->candidates[1].vertex, 43u);
  EXPECT_EQ(two->candidates[1].first, 1u);
  EXPECT_EQ(two->star[1].patch, 1u);
}

}  // namespace
}  // namespace gaussmesh::stream
