// The pieces and merge steps of the out-of-core stitch (docs/stitch.md): patch pieces per
// chunk and their joining across chunks into the sampler's patches (before the
// untriangulatable merge), with the patch adjacency and its shared feature-edge counts — from
// per-chunk records only, never the mesh.
//
// A chunk's pieces are the connected sets of the faces it *owns* with one label, joined across
// manifold non-feature edges (stream/sampling/patch_filters.h find_patches, restricted to owned faces).
// Every manifold edge between an owned face and a face owned elsewhere is a border-edge record;
// the owner of the other face emits the same edge from its side, so the stitch sees each such
// edge twice and joins the two pieces (non-feature edge) or counts one shared feature edge
// between them (feature edge). The locality contract makes both sides agree: a chunk decides
// the labels of every face sharing a vertex with an owned face exactly.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "format/status.h"
#include "stream/partition/chunk_partition.h"
#include "stream/core/memory_budget.h"
#include "stream/core/mesh_adjacency.h"
#include "stream/sampling/patch_filters.h"

namespace gaussmesh::stream {

// A piece id: chunk << 32 | index of the piece in its chunk.
using PieceId = std::uint64_t;
// No piece: a face nobody answered for.
inline constexpr PieceId kNoPiece = ~PieceId{0};

class PieceJoinFiles;  // stream/stitch/piece_joins.h

struct PieceRecord {
  PieceId piece = 0;
  std::uint32_t label = 0;     // Gaussian triangle, or kNoLabel
  std::uint64_t faces = 0;     // owned faces in the piece
  // The piece's first face in the order of (face_order_key, global id), and its key: patches
  // are numbered by it (find_patches' numbering).
  std::uint64_t min_face = 0;
  std::uint64_t min_key = 0;
  // Vector area (its faces' cross products summed in face order): set by write_loop_chunk for
  // the loops pass, zero otherwise.
  std::array<double, 3> area = {0, 0, 0};
};

struct BorderEdgeRecord {
  std::uint64_t face = 0;   // owned by the emitting chunk
  std::uint64_t other = 0;  // owned by another chunk
  PieceId piece = 0;        // piece of `face`
  bool feature = false;     // the two faces' labels differ
};

// Manifold feature edges between two pieces of one chunk.
struct PieceAdjacencyRecord {
  PieceId a = 0, b = 0;  // a < b
  std::uint64_t edges = 0;
};

// The piece of an owned face that other chunks may refer to: every owned face with a vertex
// owned elsewhere or whose vertices' stars hold a face owned elsewhere (the faces in other
// chunks' candidate stars and in the stars their loops turn through), and the faces of this
// chunk's candidate stars.
struct FacePieceRecord {
  std::uint64_t face = 0;
  PieceId piece = 0;
};

// One face of a candidate's star, in the adjacency's fan order: the face, the face across its
// edge leaving the vertex (kNoFaceId for a break edge), and whether its edge entering the vertex
// is a break. What the sampler counts as the vertex's feature edges (evaluate_vertex) is
// sum over the star of [leaving edge is a break or joins another label] + [entering edge is a
// break]: with pieces for faces, the stitch recounts it after merges change labels.
// The owners (chunks) of the two faces say whose answers the stitch reads for them.
inline constexpr std::uint64_t kNoFaceId = ~std::uint64_t{0};
// Chunks number < 2^18 (the partition's cells), so an owner fits in 31 bits.
struct StarEntry {
  std::uint64_t face = 0;
  std::uint64_t next = kNoFaceId;
  std::uint32_t owner = 0;                 // of face
  std::uint32_t next_owner : 31 = 0;       // of next (0 for a break)
  std::uint32_t entering_break : 1 = 0;
};
static_assert(sizeof(StarEntry) == 24, "one star entry per candidate face stays in memory until the stitch");

// An owned vertex with >= 3 feature edges (a candidate before the merge): its star.
struct CandidateRecord {
  std::uint32_t vertex = 0;      // global id
  std::uint32_t first = 0;       // into ChunkPieces::star
  std::uint32_t count = 0;
};

// An owned collapsed face (a repeated index): a patch of its own, whose distinct vertices count
// as candidates on it when they are candidates (plan_untriangulatable_merges).
struct CollapsedFaceRecord {
  PieceId piece = 0;
  std::uint32_t vertices[3] = {0, 0, 0};  // distinct global ids, the unused ones repeat the first
};

// What find_chunk_pieces finds in one chunk. border and border_faces grow with the chunk's
// border: PieceJoinFiles::spill moves them to disk before the next chunk; the rest grows with
// the pieces and candidates and stays for the stitch.
// Makes room for one more entry in v, a list that compact() shrinks to its distinct entries
// (summing or dropping repeats) and that held `compacted` of them after the last compaction:
// when v is full, compacts it if it is at least 2 * compacted + slack long, and if it is still
// full grows its capacity by hand to that size, where a doubling vector would overshoot by up
// to 2x.
template <typename T, typename Compact>
void make_room_for_one(std::vector<T>& v, const std::size_t& compacted, std::size_t slack, const Compact& compact) {
  if (v.size() != v.capacity()) return;
  if (v.size() >= 2 * compacted + slack) compact();
  if (v.size() == v.capacity()) v.reserve(std::max(2 * compacted + slack, v.size() + slack));
}

struct ChunkPieces {
  std::vector<PieceRecord> pieces;  // in piece index order
  std::vector<BorderEdgeRecord> border;
  std::vector<PieceAdjacencyRecord> adjacency;
  std::vector<FacePieceRecord> border_faces;  // ascending face
  std::vector<CandidateRecord> candidates;  // ascending vertex
  std::vector<StarEntry> star;
  std::vector<CollapsedFaceRecord> collapsed;
};

// The chunk owning local face f of chunk: chunk.chunk for an owned face, else the owner of its
// lowest-id vertex (its lowest local index: local vertices ascend in global id), as load_chunk
// read it from owners.bin (else from the partition's cell map, Partition::owner_of).
std::uint32_t face_owner(const Partition& partition, const ChunkMesh& chunk, std::uint32_t f);

// Pieces of one chunk of `partition` from its adjacency, labels and feature bits (stream/sampling/sampler.h,
// computed on the whole chunk mesh). Appends to out (border_faces ascend within the chunk).
// piece_index (optional): per local face, the index of its piece in this chunk (PieceId & 0xFFFFFFFF),
// or 0xFFFFFFFF for faces the chunk does not own.
// candidates (optional): the owned vertices with >= 3 feature edges, local ids ascending, as the
// sampler found them (its records' is_candidate, from the same feature bits); without it every
// owned vertex's star is counted here, repeating the sampler's own count (the sample pass hands
// them over).
void find_chunk_pieces(const Partition& partition, const ChunkMesh& chunk, const MeshAdjacency& adjacency,
                       const std::vector<std::uint32_t>& labels, const std::vector<std::uint8_t>& feature,
                       ChunkPieces& out, std::vector<std::uint32_t>* piece_index = nullptr,
                       const std::vector<std::uint32_t>* candidates = nullptr);

// The piece of every local face of chunk: owned faces through piece_index (find_chunk_pieces),
// the others through their owners' answers (PieceJoinFiles::look_up; kNoPiece where none, as
// for faces far from every owned face). Each owner's answer file is read once.
format::Status chunk_face_pieces(const Partition& partition, const ChunkMesh& chunk,
                                 const std::vector<std::uint32_t>& piece_index, const PieceJoinFiles& joins,
                                 std::vector<PieceId>& pieces);

// A patch of the stitched graph; patches are numbered by their first face by (key, id), as
// find_patches numbers them given face_order_keys.
struct StitchedPatch {
  std::uint64_t min_key = 0, min_face = 0;
  std::uint64_t faces = 0;
  std::uint32_t label = 0;
};

struct StitchedPatches {
  std::vector<StitchedPatch> patches;  // ascending (min_key, min_face)
  // (p, q, shared manifold feature edges), p < q, sorted.
  struct Adjacent {
    std::uint32_t p = 0, q = 0;
    std::uint64_t edges = 0;
  };
  std::vector<Adjacent> adjacency;
  std::vector<std::uint32_t> piece_patch;  // patch of every piece, in the order of all pieces given
  // Per chunk (and one past the last): the index of its first piece in piece_patch. A piece id's
  // index is its chunk's first plus its index in the chunk, below the next chunk's first.
  std::vector<std::uint32_t> chunk_first;
  std::int64_t piece_index(PieceId piece) const;  // -1 when unknown
  // Patch of a piece; -1 when unknown (kNoPiece included).
  std::int64_t patch_of_piece(PieceId piece) const;
  // Candidates (before the merge), ascending vertex, with their stars in patch ids.
  struct Candidate {
    std::uint32_t vertex = 0;
    std::uint32_t first = 0, count = 0;  // into star
  };
  struct Star {
    std::uint32_t patch = 0;
    std::uint32_t next_patch = 0xFFFFFFFFu;  // patch across the leaving edge; none for a break
  };
  std::vector<Candidate> candidates;
  std::vector<Star> star;
  // Per star entry: whether its entering edge is a break. Beside star rather than in it: 8 bytes
  // an entry instead of 12, and they are live through the merge.
  std::vector<std::uint8_t> entering_break;
  // Collapsed faces: their patch and distinct candidate vertices (global ids).
  struct Collapsed {
    std::uint32_t patch = 0;
    std::vector<std::uint32_t> vertices;
  };
  std::vector<Collapsed> collapsed;
};

// Joins the pieces of every chunk over the border edges in `joins` (spilled and finished; the
// join holds about bucket_bytes(budget) of them per thread at a time, read and sorted on
// `threads` threads) and resolves the candidates'
// stars to patches through the answer files of the faces' owners (each read once).
// chunks[c] holds chunk c's pieces, adjacency, candidates with their stars, and collapsed faces,
// except what PieceJoinFiles::spill took, which comes from `joins`: the pieces and adjacency when
// chunks[c].pieces is empty, the candidates and stars when both are empty. Its border and
// border_faces are ignored: they are in `joins`. Records are untrusted (they come
// back from disk): a border edge seen other than exactly twice with matching feature bits, a
// piece with two labels, a star face nobody answers for, is a kBadInput error. Memory: the
// pieces, their union-find and piece-pair feature-edge counts, the candidates' stars and the
// output — nothing per border edge or border face.
format::Result<StitchedPatches> stitch_pieces(std::vector<ChunkPieces>& chunks, const PieceJoinFiles& joins,
                                              const MemoryBudget& budget, std::uint32_t threads = 1);

// The candidates' stars as the merge's re-evaluation reads them: a candidate stays one while
// at least 3 of its star's edges are feature edges. Per candidate, the edges no merge changes
// — break edges (an entering break, or no face across the leaving edge), at most 3 counted —
// and the star's edges between two different patches, each as the positions of its two
// patches in the candidate's sorted list of the merge input (PatchGraphInput::candidate_patches):
// a byte each while the list has at most 256 patches, else the two patch ids, in `wide`. Edges
// inside one patch never count and are left out: a fraction of the stars' size
// (docs/benchmarks.md).
struct CandidateEdges {
  static constexpr std::uint8_t kWide = 0x80;  // in fixed: the candidate's edges are in wide
  std::vector<std::uint32_t> first;  // candidates + 1: candidate k's edges are narrow[first[k], first[k + 1])
  std::vector<std::uint8_t> fixed;   // per candidate: its break edges (at most 3), | kWide
  std::vector<std::array<std::uint8_t, 2>> narrow;
  struct WideCandidate {
    std::uint32_t candidate = 0, begin = 0, end = 0;  // its edges: wide[begin, end)
  };
  std::vector<WideCandidate> wide_candidates;  // ascending candidate
  std::vector<std::pair<std::uint32_t, std::uint32_t>> wide;

  // Whether candidate k has at least 3 feature edges when input patch p has label(p);
  // patches: the candidate's list in the merge input.
  template <typename Label>
  bool keeps_candidacy(std::uint32_t k, const std::uint32_t* patches, Label&& label) const {
    std::uint32_t edges = fixed[k] & 3;
    if (fixed[k] & kWide) {
      const auto it = std::lower_bound(wide_candidates.begin(), wide_candidates.end(), k,
                                       [](const WideCandidate& w, std::uint32_t c) { return w.candidate < c; });
      for (std::uint32_t e = it->begin; e < it->end && edges < 3; ++e) edges += label(wide[e].first) != label(wide[e].second);
      return edges >= 3;
    }
    for (std::uint32_t e = first[k]; e < first[k + 1] && edges < 3; ++e)
      edges += label(patches[narrow[e][0]]) != label(patches[narrow[e][1]]);
    return edges >= 3;
  }
};

// The merge: the untriangulatable-patch merge (stream/sampling/patch_filters.h, the patch-graph
// merge that sample_mesh runs in core) on the stitched patches, for the exact sample test: a
// touched candidate keeps its candidacy when its star, with the patches' current labels, still
// counts >= 3 feature edges; the merged patches come in find_patches' numbering (lowest face),
// as the in-core run's final face_patch numbers them. In two steps, so that a caller can free
// what the merge no longer reads in between: the merge's input (patches, adjacency, candidates' patch lists) and the candidates' edges are
// built from stitched's patches, adjacency, collapsed faces, candidates and star, and the first
// three are freed as they are read; the merge itself reads only the input and the edges.
// is_candidate is parallel to stitched.candidates.
PatchGraphInput take_merge_input(StitchedPatches& stitched, CandidateEdges& edges);
PatchMergeResult merge_stitched_patches(const CandidateEdges& edges, PatchGraphInput input);

}  // namespace gaussmesh::stream
