// The loops pass's records (docs/stitch.md): each chunk's feature half-edges under the
// merged patches, chained into runs with the roles of the vertices the mesher keeps
// (find_chunk_loops); the loop chunk the sample pass writes so that the loops pass reads only the
// faces near feature edges (write_loop_chunk); and a chunk's runs spilled to a record file for the
// loop stitch (spill_chunk_loops, stream/stitch/loop_stitch.h).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "format/mesh_types.h"
#include "format/record_file.h"
#include "format/status.h"
#include "stream/core/mesh_adjacency.h"
#include "stream/meshing/polygon_mesher.h"
#include "stream/partition/chunk_partition.h"
#include "stream/sampling/chunk_sampler.h"

namespace gaussmesh::stream {

// The loops pass chains the feature half-edges of a chunk's owned faces (half-edge id = 3 × global face +
// edge, patch on its left) into runs: maximal sequences in which each half-edge's successor
// around its end vertex (the polygon mesher's next_border, under the merged patches) is the next
// one. A run ends where the successor lies on a face another chunk owns; a loop that never
// leaves the chunk is one run that closes on itself. The stitch joins runs into loops by ids
// alone, so it holds one summary per run, not one record per half-edge.
struct LoopRunRecord {
  std::uint64_t first = 0;     // id of its first half-edge
  std::uint64_t next = 0;      // id of the successor of its last half-edge (another run's first)
  std::uint64_t min_id = 0;    // its lowest half-edge id (a loop starts at its lowest)
  std::uint64_t offset = 0;    // index of its first vertex in the chunk's run vertices
  std::uint32_t min_index = 0; // index of min_id in the run
  std::uint32_t length = 0;    // half-edges
  std::uint32_t patch = 0;     // merged patch on the left
  std::uint32_t breaks = 0;    // boundary or non-manifold half-edges among them
  std::uint32_t chunk = 0;
};

// The start vertex of one half-edge of a run: 16 bytes in the chunk's run file.
struct LoopVertexEntry {
  std::uint32_t vertex = 0;  // global id
  format::Vec3f position;
};

// An owned vertex the mesher must keep or place: a sample, or a corner (feature degree 1 or
// >= 3, a candidate after the merge, a boundary turn).
struct LoopVertexRecord {
  std::uint32_t vertex = 0;
  format::Vec3f position;
  std::uint32_t degree = 0;           // distinct feature edges under the merged patches
  VertexRole role = VertexRole::kNone;  // kSample or kCorner
  std::uint32_t interior_patch = 0xFFFFFFFFu;  // a sample off every feature edge: its patch
};

struct ChunkLoops {
  std::vector<LoopRunRecord> runs;
  std::vector<LoopVertexEntry> run_vertices;  // every run's start vertices, run after run
  std::vector<LoopVertexRecord> vertices;     // ascending vertex
  // Per merged patch touched: the sum of its owned faces' cross products.
  std::vector<std::pair<std::uint32_t, std::array<double, 3>>> areas;
};

// The loops pass on one chunk. patch[local face] is the merged patch of every face sharing a vertex with
// an owned face (one entry per chunk face); is_corner(global vertex) whether it is a candidate after the merge;
// samples are the chunk's owned samples (ascending). Appends to out (offsets count from the
// run vertices already there). Collapsed faces and repeats of a face's vertex set take no part
// (faces_the_mesher_skips). Errors: the adjacency's, when repeats force a second one.
// A loop chunk (chunk.core_face not empty, write_loop_chunk): only owned core faces' half-edges
// and owned loop vertices are looked at, and no areas are summed (the caller adds the pieces'
// areas, PieceRecord::area).
format::Status find_chunk_loops(const ChunkMesh& chunk, const MeshAdjacency& adjacency,
                      std::span<const std::uint32_t> patch,
                      const std::function<bool(std::uint32_t)>& is_corner, const std::vector<GlobalSample>& samples,
                      ChunkLoops& out);

// The sample pass's share of the loops pass: the loops pass needs only the faces near the merged
// patches' borders, and
// those are feature edges: an edge without its feature bit (same label, manifold) joins two faces
// of one piece, or of two pieces the stitch joins, so of one merged patch in every merge. R is
// the set of the ends of owned faces' feature edges, the owned ends of the other faces' feature
// edges, and the owned samples; core faces are the faces with a vertex in R, and the file holds
// them and every face on an edge of a core face (so every edge of a core face has all its faces,
// and every loop vertex its whole star), with the piece of each owned face and the loop vertices
// flagged. find_chunk_loops on it finds the same runs and vertex records as on the whole chunk.
// Writes it to path and sets loop_info (a copy of info for it), and returns false (nothing
// written) when the chunk has faces the mesher skips (collapsed faces, repeats: their adjacency
// differs) or the file would hold more than 3/4 of the chunk's faces.
// piece_index: find_chunk_pieces's, per local face; feature: the sampler's feature bits per local
// face (bit i: edge i), for every chunk face. piece_area gets each piece's vector area (its
// owned faces' cross products summed in face order), which the loops pass sums per merged patch.
format::Result<bool> write_loop_chunk(const ChunkMesh& chunk, const ChunkInfo& info, const MeshAdjacency& adjacency,
                                      const std::vector<std::uint32_t>& piece_index, const std::vector<std::uint8_t>& feature,
                                      const std::vector<GlobalSample>& samples, format::RecordSegmentFile& file,
                                      ChunkInfo& loop_info, std::vector<std::array<double, 3>>& piece_area);

// What the stitch keeps of a chunk's loops: its run vertices go to a file, the rest stays (until
// spill_loop_summaries moves that to a file too).
struct ChunkLoopSummary {
  std::vector<LoopRunRecord> runs;
  std::vector<LoopVertexRecord> vertices;
  std::vector<std::pair<std::uint32_t, std::array<double, 3>>> areas;
  std::string path;           // segment file holding the record file of its run vertices (kLoopVertexRecordKind)
  format::RecordSegment segment;
  std::uint64_t entries = 0;  // records in it
  std::uint64_t bytes = 0;    // its size on disk
  // Where spill_loop_summaries put runs, vertices and areas (in that order) and how many of each.
  std::uint64_t spilled_at = 0, spilled_runs = 0, spilled_vertices = 0, spilled_areas = 0;
};
inline constexpr std::uint32_t kLoopVertexRecordKind = 0x564C4D47u;  // "GMLV"

// Writes a chunk's run vertices to path (a record file) and returns the summary.
format::Result<ChunkLoopSummary> spill_chunk_loops(ChunkLoops&& loops, format::RecordSegmentFile& file);

// The summaries' runs, vertex records and areas, which grow with the output's patches and
// loops, to a plain file at path (chunk after chunk, each array as it is in memory), their
// allocations freed and their counts kept in the summaries: the mesh pass then does not hold
// them beside the mesher. kOutput when the file cannot be written.
format::Status spill_loop_summaries(std::vector<ChunkLoopSummary>& chunks, const std::string& path);
// The summaries as they were before spill_loop_summaries(chunks, path), read back from path
// (for a second loop stitch); chunks is left as it is. Sizes come from the counts in chunks,
// never from the file; a short file is kBadInput naming it.
format::Result<std::vector<ChunkLoopSummary>> read_loop_summaries(const std::vector<ChunkLoopSummary>& chunks,
                                                                  const std::string& path);

}  // namespace gaussmesh::stream
