// The pieces of the chunked finish (docs/finish.md, "Out of core: the chunked finish"): when the
// input is too large to collapse whole within --memory, it is collapsed piece by piece. A piece
// is a set of faces whose vertices carry their input ids, their fixed-point quadrics and a lock
// on every vertex the piece shares with another one; it is collapsed to its share of the target
// with its locked vertices in place, so that pieces collapsed apart still fit together.
#pragma once

#include <cstdint>
#include <vector>

#include "format/mesh_types.h"
#include "stream/finish/quadric.h"
#include "stream/finish/quadric_decimation.h"
#include "stream/partition/chunk_partition.h"

namespace gaussmesh::stream {

struct PieceVertex {
  std::uint32_t id = 0;  // the input vertex it is, or the one it kept of those it absorbed
  format::Vec3f position;
  FixedQuadric quadric;
  std::uint8_t locked = 0;
};

struct Piece {
  std::vector<PieceVertex> vertices;     // ascending id
  std::vector<format::Triangle> faces;   // indices into vertices
};

struct PieceResult {
  Piece piece;  // what is left: survivors in ascending id; a locked vertex keeps its input bits
  std::uint64_t collapses = 0, refused = 0, over_error = 0;
  double estimated_error = 0;  // frame units
  bool manifold = true;        // false: not an oriented manifold, returned as it was
};

// Collapses `piece` (quadrics and positions in `frame`) as `options` asks; options.locked is set
// from the piece's flags, and the quadrics already hold the boundary constraints.
PieceResult decimate_piece(Piece piece, const QuadricFrame& frame, DecimationOptions options);

// The first round's pieces of one partition chunk: its owned faces (those with a repeated corner
// left out) in at most ⌈owned / max_piece_faces⌉ pieces of nearby faces. A vertex is locked when
// a face around it (in the whole input) is not in its piece; every face's plane goes to its
// corners, and every edge of the input's boundary carries its constraint plane
// (boundary_constraint), both once in the whole input whatever the chunks. Needs a chunk with
// at least two overlap rings, which hold every face around every corner of an owned face.
std::vector<Piece> chunk_pieces(const ChunkMesh& chunk, const QuadricFrame& frame, std::uint64_t max_piece_faces);

}  // namespace gaussmesh::stream
