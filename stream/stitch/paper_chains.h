// The paper sample test out of core (docs/stitch.md, "Chains"): what sample_mesh
// does after the untriangulatable merge — the candidates' records under the merged labels, the
// candidate adjacency along feature chains (find_candidate_adjacency) and the noisy-sample filter
// (paper §4 "Noisy Sample Filtering", Figs. 9-10) — from per-chunk records joined across chunks.
//
// - The sample pass writes each owned candidate's *star geometry* (its position; per star slot, in the
//   adjacency's fan order: the fan flags, the face normal after smoothing, whether the face is
//   degenerate, and the position of the vertex across its leaving edge). After the merge the
//   stitch re-evaluates every surviving candidate from it with the labels of the merged patches
//   (evaluate_vertex_list on a mesh made of the star alone), which is what sample_mesh's merge
//   left in its records.
// - The chains pass, per chunk, follows the feature edges of the vertices the chunk owns under the
//   merged labels: candidate pairs joined by a feature edge, and the chain pieces through owned
//   non-candidates (each of which has exactly two feature-edge sides). A piece whose two ends are
//   candidates is a pair; one that leaves the chunk is a *fragment*, written to disk.
// - The fragment join unites fragments across the feature edges they leave by, and each chain
//   that reaches two distinct candidates gives a pair: the pairs of find_candidate_adjacency.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "format/record_file.h"
#include "format/status.h"
#include "stream/partition/chunk_partition.h"
#include "stream/core/gauss_sphere.h"
#include "stream/core/memory_budget.h"
#include "stream/core/mesh.h"
#include "stream/core/mesh_adjacency.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::stream {

// "GMSG": one star-geometry record: u32 id, 3 × f32 a, 3 × f32 b, u8 flags. A vertex record
// (flags bit 7) opens each candidate: id = global vertex, a = its position. Slot records follow,
// one per slot of its star in fan order: a = the face's normal, b = the position of the vertex
// across the edge leaving the candidate, flags bits 0-1 = the slot's MeshAdjacency flags
// (kFanStart, kFanClosed), bit 2 = the face is degenerate; id = 0.
inline constexpr std::uint32_t kStarGeometryRecordKind = 0x47534D47u;
inline constexpr std::uint32_t kStarGeometryRecordBytes = 29;
// "GMCF": one chain fragment: u64 end 0, u64 end 1, u8 kinds (bit k: end k is a link). An end is
// a candidate's global id, or a link: the feature edge the chain leaves the chunk by, as
// (from << 32 | to), from the vertex this chunk owns to the one it does not.
inline constexpr std::uint32_t kChainFragmentRecordKind = 0x46434D47u;
inline constexpr std::uint32_t kChainFragmentRecordBytes = 17;

// Where a per-chunk record file lies (a segment of a segments-N.rec file) and how many records it holds.
struct ChunkRecordSegment {
  std::string path;  // empty: none
  format::RecordSegment segment;
  std::uint64_t records = 0;
};

// The sample pass: the star geometry of the candidates among `records` (evaluate_vertex_list's, over the
// chunk's owned vertices: local ids, ascending), from the chunk's adjacency and normals, appended
// to `file` as one record file. Errors: kOutput.
format::Result<ChunkRecordSegment> write_star_geometry(const ChunkMesh& chunk, const MeshAdjacency& adjacency,
                                                       const FaceNormals& normals, std::span<const VertexRecord> records,
                                                       format::RecordSegmentFile& file);

// A candidate after the merge, as the noisy filter and the outputs need it.
struct PaperCandidate {
  std::uint32_t vertex = 0;  // global id
  std::uint32_t chunk = 0;   // its owner
  format::Vec3f position;
  std::uint32_t gauss_vertex = kNoGaussVertex;
  Characteristic characteristic = Characteristic::kNone;
  std::uint8_t cover_mask = 0;
  bool is_tree = false;
};

// One slot of a candidate's star under the merged labels: its face's label and whether the edge
// leaving the candidate there is a feature edge.
struct StarSlotLabel {
  std::uint32_t label = 0;
  bool feature = false;
};
// star(vertex, slots): false when vertex is no candidate after the merge (its records are
// skipped); else the labels of its star's slots in fan order.
using MergedStar = std::function<bool(std::uint32_t vertex, std::vector<StarSlotLabel>& slots)>;

// After the merge: re-evaluates the chunk's candidates that `star` names from their star geometry
// (`geometry`, written by write_star_geometry) and appends them to out (ascending vertex). Same
// decisions as sample_mesh's records after its merge. Errors: a damaged file, a star whose slot
// count differs from the geometry's, a candidate that is none under the labels (kBadInput).
format::Status reevaluate_candidates(const ChunkRecordSegment& geometry, std::uint32_t chunk, const GaussSphere& gauss,
                                     const MergedStar& star, std::vector<PaperCandidate>& out);

struct ChainFragment {
  std::uint64_t end[2] = {0, 0};
  std::uint8_t links = 0;  // bit k: end[k] is a link
};

// The chain pass for one chunk: label[f] is the merged label of every face in the star of an
// owned vertex the chunk looks at (all owned vertices; for a loop chunk, its owned loop vertices)
// and `known[f]` says which faces have one; is_candidate(global id) the candidacy after the merge.
// Appends (a, b), a < b, for candidates joined in the chunk, and the fragments that leave it.
// Errors (kBadInput, "chain"): a face around such a vertex without a label, an owned vertex whose
// feature-edge count disagrees with its candidacy, a chain piece without exactly 0 or 2 ends.
format::Status find_chunk_chains(const ChunkMesh& chunk, const MeshAdjacency& adjacency,
                                 std::span<const std::uint32_t> label, std::span<const std::uint8_t> known,
                                 const std::function<bool(std::uint32_t)>& is_candidate,
                                 std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs,
                                 std::vector<ChainFragment>& fragments);

// Writes fragments to `file` as one record file (nothing when empty). Errors: kOutput.
format::Result<ChunkRecordSegment> write_chain_fragments(std::span<const ChainFragment> fragments,
                                                         format::RecordSegmentFile& file);

// Joins the fragments of every chunk across their links and appends a pair for each chain that
// ends at two distinct candidates. Memory: 4 bytes per fragment (a union-find) plus the links of
// one part at a time (about 1/16 of the budget, at least 1 MiB; the files are read once per part)
// and the candidate ends. Errors: a damaged file, a link not seen as often from each side, a
// chain with one or more than two candidate ends (kBadInput).
format::Status join_chain_fragments(std::span<const ChunkRecordSegment> files, const MemoryBudget& budget,
                                    std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs);

// A digest of a sorted, duplicate-free pair list (FNV-1a over the ids): the report's and the
// tests' check that out of core finds find_candidate_adjacency's pairs.
std::uint64_t candidate_pairs_digest(std::span<const std::pair<std::uint32_t, std::uint32_t>> pairs);

}  // namespace gaussmesh::stream
