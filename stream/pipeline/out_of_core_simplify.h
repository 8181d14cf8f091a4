// `gaussmesh simplify --memory`: the out-of-core simplify pipeline (docs/pipeline.md). Its
// passes, in order:
//   ingest, partition  the input written as chunks on disk (stream/partition/chunk_partition.h);
//   sample             every chunk sampled for every orientation (stream/sampling/chunk_sampler.h),
//                      and the chosen orientation's patch pieces and loop chunks written
//                      (stream/stitch/chunk_pieces.h, loop_chunks.h);
//   the stitch:
//     pieces           the pieces joined across chunks into patches (stream/stitch/piece_joins.h);
//     merge            the untriangulatable merge on the patch graph;
//     chains           the paper sample test only: its candidates re-evaluated from their star
//                      geometry, candidate pairs along feature chains, the noisy filter
//                      (stream/stitch/paper_chains.h);
//     loops            each chunk's feature half-edges under the merged patches, chained into
//                      runs, without labelling the chunk again (find_chunk_loops);
//     loop stitch      the runs joined into patch loops (stream/stitch/loop_stitch.h);
//   mesh               the polygon-first mesher on the loops (stream/meshing/polygon_mesher.h,
//                      mesh_patch_loops), with fetch rounds that read the input faces of the
//                      patches that need them.
// Every pass sees records, not the mesh, and the output equals the in-core simplify's, triangle
// for triangle. Every pass draws its memory from one budget (OutOfCoreSimplifyOptions::memory).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "format/mesh_reader.h"
#include "format/mesh_writer.h"
#include "format/status.h"
#include "stream/attributes/attribute_transfer.h"
#include "stream/core/gauss_sphere.h"
#include "stream/core/memory_budget.h"
#include "stream/core/mesh.h"
#include "stream/finish/quadric_finish.h"
#include "stream/meshing/polygon_mesher.h"
#include "stream/partition/chunk_partition.h"
#include "stream/pipeline/out_of_core_finish.h"
#include "stream/sampling/chunk_sampler.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::stream {

struct OutOfCoreSimplifyOptions {
  PartitionOptions partition;  // tmp dir, chunk size; its memory, rings and threads follow from the fields below
  MemoryBudget memory{PartitionOptions{}.memory_bytes};  // --memory: the working set every pass shares
  std::uint32_t threads = 1;   // chunks in flight (--threads)
  std::vector<GaussSphereOptions> spheres = {GaussSphereOptions{}};
  std::uint64_t min_samples = 0;  // the sphere choice, as SimplifyOptions::min_samples
  // The quadric finish (stream/finish/): resolved against the input once the partition knows
  // its faces and bounds; when it asks for something, min_samples follows from it too (set
  // auto_frequency for that) and a quadrics pass over the chunks runs after the mesh pass.
  FinishTarget finish;
  bool auto_frequency = false;
  // `memory` was given by the user: a target whose approximation would not fit it is refused
  // (kResources) rather than run past it. Otherwise the passes that hold the approximation
  // take what it needs (finish_memory_estimate).
  bool memory_explicit = false;
  std::uint64_t memory_ceiling = 0;  // how far the automatic budget may grow for the finish (0: no limit)
  // Collapse the input chunk by chunk (stream/pipeline/out_of_core_finish.h) even when it would fit
  // whole: tests set it to exercise the chunked finish on small inputs.
  bool always_chunked_finish = false;
  // Round 2 of the chunked finish, before a round of one piece, aims at the target only with at
  // most this share of it at locked vertices (kLastRoundLockedShareBeforeOnePiece; tests compare
  // other shares).
  double last_round_locked_share_before_one_piece = kLastRoundLockedShareBeforeOnePiece;
  // What the output costs a face when its writer needs it whole (Draco, a memory sink; 0 when it
  // streams): with an explicit budget a chunked finish whose target would not fit is refused
  // before it starts, not after.
  std::uint64_t whole_output_bytes_per_face = 0;
  SamplerOptions sampler;
  // (pass name, chunks done, chunks, input faces) after each chunk.
  std::function<void(const char*, std::size_t, std::size_t, std::uint64_t)> progress;
  // Stop once the samples are known (after the merge and, for the paper test, the chains pass):
  // no loops, no mesh; OutOfCoreSimplify::sample_points holds them (`sample --memory` with the
  // paper test, whose samples need the stitch).
  bool samples_only = false;
};

// The chunked finish's figures (out_of_core_finish.h), when it ran.
struct ChunkedFinishFigures {
  std::vector<std::uint64_t> round_pieces, round_faces;  // per round: pieces, faces left after it
  std::vector<std::uint64_t> round_locked_faces;         // rounds 2, 3, …: faces at locked vertices
  std::vector<double> seconds_rounds;
  std::uint64_t largest_piece = 0, unheld_pieces = 0;
};

struct OutOfCoreSimplify {
  Mesh mesh;  // after the finish, when there is one; empty when `parts` holds the output
  // The chunked finish's output, read from temporary files as it is written (it holds them).
  std::shared_ptr<format::MeshParts> parts;
  FinishOptions finish_options;        // the resolved target
  std::optional<FinishResult> finish;  // its figures (its mesh moved into `mesh`)
  std::uint64_t finish_memory_estimate = 0;  // --frequency auto: what the chosen approximation needs
  bool collapsed_input = false;  // the finish ran on the input itself, not on a Gauss approximation
  std::optional<ChunkedFinishFigures> chunked;  // it did, piece by piece (the input did not fit whole)
  std::vector<std::uint32_t> birth;
  std::array<double, 4> rotation{};
  std::size_t chosen = 0;
  std::vector<std::size_t> samples_per_orientation;
  std::size_t gauss_vertices = 0, gauss_triangles = 0;
  std::size_t patches = 0, candidates = 0, samples = 0, merged_patches = 0, merge_rounds = 0;
  // samples_only: the samples, ascending vertex, with their positions.
  std::vector<GlobalSample> sample_points;
  ChunkSamplingStats sampling_stats;  // the sample pass's counts, of the chosen orientation
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
  std::size_t fetched_patches = 0, fetched_faces = 0;  // the fetch pass: input faces for the mesher's last steps
  std::size_t fetched_chunks = 0;  // chunks read for them (those owning faces of the patches), over all rounds
  // The loops pass: chunks it read as loop chunks (write_loop_chunk), and the faces it loaded in all.
  std::size_t loop_chunks = 0;
  std::uint64_t loop_faces = 0;
  bool reordered = false;  // the input was renumbered first (PartitionOptions::reorder_scattered)
  std::uint64_t welded_vertices = 0;  // welded away by it (vertices counts the rest)
  format::AttributeKinds input_attributes;                // Partition's
  std::shared_ptr<VertexAttributeSpill> attribute_spill;  // Partition's
  // With attribute_spill, when the finish collapsed the input: its triangles (every chunk's owned
  // faces), what surface_values needs, read from the partition's files, which `parts` holds (a
  // chunked finish) or `input_partition` (the input held whole); empty otherwise. Resetting
  // input_partition removes the files.
  TrianglePassFn input_triangles;
  std::shared_ptr<Partition> input_partition;
  std::vector<std::string> ignored_vertex_values;    // Partition's
  std::vector<std::string> input_warnings;           // Partition's
  double seconds_reorder = 0;
  double seconds_ingest = 0, seconds_partition = 0, seconds_sample = 0, seconds_stitch = 0, seconds_mesh = 0;
  double seconds_cleanup = 0;  // removing the temporary directory (the file system's writeback can stall it)
  PartitionSteps partition_steps;  // seconds_partition by step
  ReorderSteps reorder_steps;      // seconds_reorder by step
  // seconds_stitch by step: pieces (joined across chunks), merge, loops (on the chunks' threads),
  // the loop stitch; and for the paper test, chains (its candidates' records, chains and filters,
  // after the merge, before the loops).
  struct StitchSteps {
    double pieces = 0, merge = 0, chains = 0, loops = 0, loop_stitch = 0;
  } stitch_steps;
  // The process's peak RSS (getrusage) after the partition, after the sample pass (which finds the
  // pieces), after the merge, and after the loops: which pass sets the peak.
  std::uint64_t peak_rss_after_partition = 0, peak_rss_after_pieces = 0, peak_rss_after_merge = 0,
                peak_rss_after_loops = 0;
};

// The whole job. With the paper test and several orientations, the passes up to the samples run
// once per orientation, and once more to the end for the chosen one (unless samples_only).
// Errors: kUsage for bad options; the partition's and the chunks' (bad input, temp files,
// resources); kBadInput for damaged records; kProcessing from the stitch or the mesher
// (including patches that still ask for input faces after the fetch rounds).
format::Result<OutOfCoreSimplify> simplify_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                       const OutOfCoreSimplifyOptions& options);

}  // namespace gaussmesh::stream
