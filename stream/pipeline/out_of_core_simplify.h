// `gaussmesh simplify --memory`: the out-of-core pipeline (DESIGN §2, docs/out-of-core.md).
// Pass 0-1 partition the input (stream/partition/chunk_partition.h); pass A samples every chunk for every
// orientation (stream/sampling/chunk_sampler.h); pass B finds the patch pieces of the chosen orientation
// and the stitch joins them and runs the untriangulatable merge on the patch graph
// (stream/stitch/chunk_pieces.h); for the paper sample test, whose samples come after the merge, the
// candidates are re-evaluated from their star geometry and a chain pass finds the candidate
// pairs along feature chains for the noisy filter (stream/stitch/paper_chains.h), once per orientation;
// pass C — from each chunk's adjacency and the pieces pass A/B wrote
// for its owned faces, without labelling the chunk again — gives every owned feature half-edge
// its successor around its end vertex under the merged patches, with the role of every owned
// kept vertex (find_chunk_loops, in runs); the stitch chains the runs into patch loops and the
// polygon-first mesher runs on them (stream/meshing/polygon_mesher.h, mesh_patch_loops). Every step sees records, not
// the mesh, and the output equals the in-core simplify's, triangle for triangle.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "format/mesh_reader.h"
#include "format/status.h"
#include "stream/partition/chunk_partition.h"
#include "stream/stitch/chunk_pieces.h"
#include "stream/sampling/chunk_sampler.h"
#include "stream/core/mesh.h"
#include "stream/meshing/polygon_mesher.h"

namespace gaussmesh::stream {

// Pass C chains the feature half-edges of a chunk's owned faces (half-edge id = 3 × global face +
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

// Pass C for one chunk. patch[local face] is the merged patch of every face sharing a vertex with
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

// Pass A's share of pass C: pass C needs only the faces near the merged patches' borders, and
// those are feature edges: an edge without its feature bit (same label, manifold) joins two faces
// of one piece, or of two pieces the stitch joins, so of one merged patch in every merge. R is
// the set of the ends of owned faces' feature edges, the owned ends of the other faces' feature
// edges, and the owned samples; core faces are the faces with a vertex in R, and the file holds
// them and every face on an edge of a core face (so every edge of a core face has all its faces,
// and every loop vertex its whole star), with the piece of each owned face and the loop vertices
// flagged. find_chunk_loops on it finds the same runs and vertex records as on the whole chunk.
// Until session 17 R also held every owned vertex with a face of another owner, and the ends of
// every edge between an owned face and another owner's: the chunk's whole border, where labels
// mostly do not change (100M refined cow: pass C read 17.7M faces, now 8.6M; docs/out-of-core.md).
// Writes it to path and sets loop_info (a copy of info for it), and returns false (nothing
// written) when the chunk has faces the mesher skips (collapsed faces, repeats: their adjacency
// differs) or the file would hold more than 3/4 of the chunk's faces.
// piece_index: find_chunk_pieces's, per local face; feature: the sampler's feature bits per local
// face (bit i: edge i), for every chunk face. piece_area gets each piece's vector area (its
// owned faces' cross products summed in face order), which pass C sums per merged patch.
format::Result<bool> write_loop_chunk(const ChunkMesh& chunk, const ChunkInfo& info, const MeshAdjacency& adjacency,
                                      const std::vector<std::uint32_t>& piece_index, const std::vector<std::uint8_t>& feature,
                                      const std::vector<GlobalSample>& samples, format::RecordSegmentFile& file,
                                      ChunkInfo& loop_info, std::vector<std::array<double, 3>>& piece_area);

// What the stitch keeps of a chunk's pass C: its run vertices go to a file, the rest stays.
struct ChunkLoopSummary {
  std::vector<LoopRunRecord> runs;
  std::vector<LoopVertexRecord> vertices;
  std::vector<std::pair<std::uint32_t, std::array<double, 3>>> areas;
  std::string path;           // segment file holding the record file of its run vertices (kLoopVertexRecordKind)
  format::RecordSegment segment;
  std::uint64_t entries = 0;  // records in it
  std::uint64_t bytes = 0;    // its size on disk
};
inline constexpr std::uint32_t kLoopVertexRecordKind = 0x564C4D47u;  // "GMLV"

// Writes a chunk's run vertices to path (a record file) and returns the summary.
format::Result<ChunkLoopSummary> spill_chunk_loops(ChunkLoops&& loops, format::RecordSegmentFile& file);

// The stitch's last step before the mesher: runs joined into loops (each patch's loops from
// their lowest half-edge id, as mesh_patch_polygons walks them), vertices renumbered densely in
// global id order. The loops (4 bytes per half-edge) and the positions (dense order) go to
// files in dir that the mesher reads on demand (PolygonGraphInput::loop_source, position_source). Records are untrusted: runs that do not close into
// loops, run files that disagree with their summaries, are kBadInput.
// extra_vertices: (global id, position) of vertices no record names — the inner vertices of
// fetched patch faces — added with no role. Free pages go back to the system between its steps.
struct LoopStitchStats {
  std::size_t runs = 0, half_edges = 0, vertices = 0;
};
format::Result<PolygonGraphInput> stitch_loops(const std::vector<ChunkLoopSummary>& chunks, std::size_t patches,
                                               const std::vector<format::Vec3f>& plane_normal, const std::string& dir,
                                               const std::vector<std::pair<std::uint32_t, format::Vec3f>>& extra_vertices = {},
                                               LoopStitchStats* stats = nullptr);

struct OutOfCoreSimplifyOptions {
  PartitionOptions partition;  // memory, tmp dir; rings and threads follow from the fields below
  std::uint32_t threads = 1;
  std::vector<GaussSphereOptions> spheres = {GaussSphereOptions{}};
  SamplerOptions sampler;
  // (pass name, chunks done, chunks, input faces) after each chunk.
  std::function<void(const char*, std::size_t, std::size_t, std::uint64_t)> progress;
  // Stop once the samples are known (after the merge and, for the paper test, the chain pass):
  // no loops, no mesh; OutOfCoreSimplify::sample_points holds them (`sample --memory` with the
  // paper test, whose samples need the stitch).
  bool samples_only = false;
};

struct OutOfCoreSimplify {
  Mesh mesh;
  std::vector<std::uint32_t> birth;
  std::array<double, 4> rotation{};
  std::size_t chosen = 0;
  std::vector<std::size_t> samples_per_orientation;
  std::size_t gauss_vertices = 0, gauss_triangles = 0;
  std::size_t patches = 0, candidates = 0, samples = 0, merged_patches = 0, merge_rounds = 0;
  // samples_only: the samples, ascending vertex, with their positions.
  std::vector<GlobalSample> sample_points;
  ChunkSamplingStats sampling_stats;  // pass A's counts, of the chosen orientation
  // The paper test: candidate pairs along feature chains, chain fragments that left their chunk
  // (joined on disk, stream/stitch/paper_chains.h), and what the filters removed.
  std::size_t candidate_pairs = 0, chain_fragments = 0;
  std::uint64_t candidate_pairs_digest = 0;  // candidate_pairs_digest (stream/stitch/paper_chains.h) of the pairs
  std::size_t tree_filtered = 0, unwinding_filtered = 0, noisy_filtered = 0;
  PolygonMesherStats polygon;
  std::uint64_t vertices = 0, faces = 0;
  std::size_t chunks = 0;
  std::uint64_t bytes_spilled = 0;
  std::size_t stitch_half_edges = 0;  // half-edges of the stitched loops (4 bytes each in memory)
  std::size_t stitch_runs = 0;        // run summaries the stitch joined
  std::size_t stitch_vertices = 0;    // loop vertices (positions on disk, 5 bytes each in memory)
  std::size_t fetched_patches = 0, fetched_faces = 0;  // input faces fetched for the mesher's last steps
  std::size_t fetched_chunks = 0;  // chunks read for them (those owning faces of the patches), over all rounds
  // Pass C: chunks it read as loop chunks (write_loop_chunk), and the faces it loaded in all.
  std::size_t loop_chunks = 0;
  std::uint64_t loop_faces = 0;
  double seconds_ingest = 0, seconds_partition = 0, seconds_sample = 0, seconds_stitch = 0, seconds_mesh = 0;
  double seconds_cleanup = 0;  // removing the temporary directory (the file system's writeback can stall it)
  PartitionSteps partition_steps;  // seconds_partition by step
  // seconds_stitch by step: joining the pieces across chunks, the untriangulatable merge, pass C
  // (loops under the merged patches, on the chunks' threads), the loop stitch; and for the paper
  // test, its candidates' records, chains and filters (after the merge, before pass C).
  struct StitchSteps {
    double pieces = 0, merge = 0, chains = 0, loops = 0, loop_stitch = 0;
  } stitch_steps;
  // The process's peak RSS (getrusage) after passes 0-1, after pass A/B, after the piece stitch
  // and merge, and after pass C: which stage sets the peak.
  std::uint64_t peak_rss_after_partition = 0, peak_rss_after_pieces = 0, peak_rss_after_merge = 0,
                peak_rss_after_loops = 0;
};

// The whole job. With the paper test and several orientations, the passes up to the samples run
// once per orientation, and once more to the end for the chosen one (unless samples_only).
// Errors: kUsage for bad options; the partition's and the
// chunks' (bad input, temp files, resources); kProcessing from the stitch or the mesher
// (including a patch that only its input faces could mesh, which is not fetched yet).
format::Result<OutOfCoreSimplify> simplify_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                       const OutOfCoreSimplifyOptions& options);

}  // namespace gaussmesh::stream
