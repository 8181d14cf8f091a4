// The first step of the out-of-core stitch (docs/out-of-core.md, "Pass 3 for simplify"): patch
// pieces per chunk and their joining across chunks into the sampler's patches (before the
// untriangulatable merge), with the patch adjacency and its shared feature-edge counts — from
// per-chunk records only, never the mesh.
//
// A chunk's pieces are the connected sets of the faces it *owns* with one label, joined across
// manifold non-feature edges (stream/patch_filters.h find_patches, restricted to owned faces).
// Every manifold edge between an owned face and a face owned elsewhere is a border-edge record;
// the owner of the other face emits the same edge from its side, so the stitch sees each such
// edge twice and joins the two pieces (non-feature edge) or counts one shared feature edge
// between them (feature edge). The locality contract makes both sides agree: a chunk decides
// the labels of every face sharing a vertex with an owned face exactly.
#pragma once

#include <cstdint>
#include <vector>

#include "format/status.h"
#include "stream/chunk_partition.h"
#include "stream/mesh_adjacency.h"

namespace gaussmesh::stream {

// A piece id: chunk << 32 | index of the piece in its chunk.
using PieceId = std::uint64_t;

struct PieceRecord {
  PieceId piece = 0;
  std::uint32_t label = 0;     // Gaussian triangle, or kNoLabel
  std::uint64_t faces = 0;     // owned faces in the piece
  std::uint64_t min_face = 0;  // lowest global face id
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

struct ChunkPieces {
  std::vector<PieceRecord> pieces;  // in piece index order
  std::vector<BorderEdgeRecord> border;
  std::vector<PieceAdjacencyRecord> adjacency;
};

// Pieces of one chunk from its adjacency, labels and feature bits (stream/sampler.h, computed on
// the whole chunk mesh). Appends to out.
void find_chunk_pieces(const ChunkMesh& chunk, const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                       const std::vector<std::uint8_t>& feature, ChunkPieces& out);

// A patch of the stitched graph; patches are numbered by lowest face, as find_patches numbers
// them.
struct StitchedPatch {
  std::uint64_t min_face = 0;
  std::uint64_t faces = 0;
  std::uint32_t label = 0;
};

struct StitchedPatches {
  std::vector<StitchedPatch> patches;  // ascending min_face
  // (p, q, shared manifold feature edges), p < q, sorted.
  struct Adjacent {
    std::uint32_t p = 0, q = 0;
    std::uint64_t edges = 0;
  };
  std::vector<Adjacent> adjacency;
  std::vector<std::uint32_t> piece_patch;  // patch of every piece, in the order of all pieces given
};

// Joins the pieces of every chunk. Records are untrusted (they come back from disk): a border
// edge seen other than exactly twice with matching feature bits, or a piece with two labels, is a
// kBadInput error. Memory: the pieces, the border edges (sorted in place) and the output.
format::Result<StitchedPatches> stitch_pieces(std::vector<ChunkPieces>& chunks);

}  // namespace gaussmesh::stream
