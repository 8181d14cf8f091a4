// Pass 2 of the out-of-core pipeline for sampling (DESIGN §2, docs/out-of-core.md): every chunk
// of a Partition is loaded, sampled for the vertices it owns with the sampler's local functions
// (stream/sampling/sampler.h, steps 1-2), and released, chunks in parallel (oneTBB) in bounded memory.
// The exact sample test is a per-vertex decision, so the samples equal the in-core run's for any
// chunking (the locality contract, tests/stream/locality_test.cpp). The paper test's patch-level
// filters — the untriangulatable merge and the noisy filter — need the stitch of patch pieces and
// candidate chains across chunks: sample_out_of_core runs simplify's stitch up to the samples.
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
#include "stream/core/gauss_sphere.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::stream {

// A sample with its global input vertex id and a copy of its position (no mesh is kept).
struct GlobalSample {
  std::uint32_t vertex = 0;
  format::Vec3f position;
  std::uint32_t gauss_vertex = kNoGaussVertex;
  Characteristic characteristic = Characteristic::kNone;
};

// Counts over the vertices and faces a chunk owns (so they add up over chunks to the whole
// mesh's).
struct ChunkSamplingStats {
  std::size_t owned_vertices = 0, owned_faces = 0, chunk_faces = 0;
  std::size_t degenerate_faces = 0, unlabelled_faces = 0;
  std::size_t candidates_initial = 0, exact_samples = 0;
  void add(const ChunkSamplingStats& o);
};

// Buffers reused across the chunks one thread samples.
struct ChunkSamplerWorkspace {
  MeshAdjacency adjacency;
  FaceNormals normals;
  std::vector<float> area;
  std::vector<format::Vec3f> smoothed;
  std::vector<std::uint32_t> labels, owned;
  std::vector<std::uint8_t> feature;
  std::vector<VertexRecord> records;
};

// Samples one chunk: for the exact test, appends the chunk's owned exact samples to `samples`
// (ascending global id); for the paper test, whose samples need the stitch (stream/stitch/paper_chains.h),
// appends none and leaves the owned candidates' records in workspace.records (paper decisions
// only, as sample_mesh makes them). Adds the chunk's counts to `stats` either way. Precondition:
// the chunk holds required_overlap_rings(options.smooth_iterations) rings around its owned
// vertices. Errors: those of build_mesh_adjacency.
format::Status sample_chunk(const ChunkMesh& chunk, const GaussSphere& gauss, const SamplerOptions& options,
                            ChunkSamplerWorkspace& workspace, std::vector<GlobalSample>& samples,
                            ChunkSamplingStats& stats);

// Chunk size for pass 2 from the memory budget: pass 2 holds, per thread in flight, the decoded
// chunk and the sampler's arrays, which keep the capacity of the largest chunk seen. The process
// itself (binary, TBB, reader window, samples) takes ~20 MiB. Per face of the target, 28 B per
// overlap ring and one more (112 B at the default 3 rings; smoothing adds rings, and the overlap
// grows with them). Measured (refined cow, 64M, 2 threads): the peak grows by 80-87 B a target
// face per thread in flight (1.3x slack at 3 rings). Fewer chunks make the partition cheaper
// (fewer files, larger staged frames, fewer overlap records); pass A does not change. Session 17,
// 128 -> 112 B at 100M: 768 -> 672 chunks, 22.99 / 22.64 / 22.88 -> 22.68 / 21.33 / 21.08 s
// (alternated), peak 50-51 -> 53-56 MiB; 1M and 10M 52-55 MiB. 128 B in session 16, 192 before,
// 256 until session 11.
std::uint64_t pass_two_chunk_faces(std::uint64_t memory_bytes, std::uint32_t threads, std::uint32_t rings = 3);

// Loads every chunk of `partition`, `threads` at a time (a oneTBB task arena), and calls
// body(chunk index, chunk, this thread's workspace); then progress(chunks done, chunks), from one
// thread at a time. The first error stops the chunks not yet started and is returned.
// memory_bytes (0: no check): the pass's budget. Each chunk allocates and frees arrays of its own
// size, so the allocator's arenas fill with free pages that stay resident (measured at 100M
// triangles under 64 MiB: 25-35 MB in use, 55-90 MB of arenas; 68 MB peak without releases,
// 64 MB with them, one arena). When the resident set passes 7/8 of the budget and has grown by
// 1/8 of it (at least 8 MiB) since the last release, free pages go back to the system
// (release_free_memory) — not after every chunk: re-touching released pages is costly (a
// release after every chunk made pass A 4x slower at 100M).
using ChunkBody = std::function<format::Status(std::size_t, const ChunkMesh&, ChunkSamplerWorkspace&)>;
format::Status for_each_chunk(const Partition& partition, std::uint32_t threads, const ChunkBody& body,
                              const std::function<void(std::size_t, std::size_t)>& progress,
                              std::uint64_t memory_bytes = 0);
// The same over `count` chunk files that info_of(i) describes (simplify's loop chunks): built
// when loaded, so that no second list of every chunk's paths is held.
format::Status for_each_chunk(std::size_t count, const std::function<ChunkInfo(std::size_t)>& info_of, std::uint32_t threads,
                              const ChunkBody& body, const std::function<void(std::size_t, std::size_t)>& progress,
                              std::uint64_t memory_bytes = 0);

// Passes 0-1 for the chunk passes: options' memory and tmp dir, the overlap the sampler's
// smoothing needs, chunks sized for `threads` in flight (unless max_chunk_faces is set).
format::Result<Partition> partition_for_chunks(const std::string& input_path, const format::ReadOptions& read,
                                               const PartitionOptions& options, const SamplerOptions& sampler,
                                               std::uint32_t threads);

// kUsage when an out-of-core run (`command` names it in the message) cannot take these options:
// no orientation, or 0 threads.
format::Status check_out_of_core_options(const char* command,
                                         const std::vector<GaussSphereOptions>& spheres, std::uint32_t threads);

// The process's peak RSS so far (getrusage), in bytes.
std::uint64_t peak_rss();
// The process's resident set now (0 where unknown).
std::uint64_t current_rss();

// Copies what passes 0-1 measured into an out-of-core result (OutOfCoreSampling or
// OutOfCoreSimplify: input counts, chunks, seconds) and notes the peak RSS after them.
template <class Result>
void record_partition(const Partition& partition, Result& out) {
  out.vertices = partition.vertices;
  out.faces = partition.faces;
  out.chunks = partition.chunks.size();
  out.seconds_ingest = partition.seconds_ingest;
  out.seconds_partition = partition.seconds_partition;
  out.partition_steps = partition.steps;
  out.peak_rss_after_partition = peak_rss();
}

// Hands the allocator's free pages back to the system (glibc's malloc_trim; elsewhere nothing).
// Between passes and the stitch's steps: what one step freed is not held, resident, under the
// next one's allocations. for_each_chunk calls it when its chunks are done. Session 13 made
// these releases unconditional (they waited for the resident set to pass 7/8 of the budget):
// at 100M triangles under 64 MiB the stitch and merge peaked 10 MiB above their data on the
// free pages pass A left; at 1M the next pass faults the pages in again (13k -> 30k minor
// faults, +0.05 s of system time, the wall time within its noise).
void release_free_memory();

// The Gaussian spheres of `options` (kUsage for bad options).
format::Result<std::vector<GaussSphere>> create_spheres(const std::vector<GaussSphereOptions>& options);

struct OutOfCoreSamplingOptions {
  PartitionOptions partition;  // memory, tmp dir; rings and threads are set from the fields below
  std::uint32_t threads = 1;   // chunks in flight (--threads)
  std::vector<GaussSphereOptions> spheres = {GaussSphereOptions{}};  // orientations to try
  SamplerOptions sampler;
  // Called after each chunk of pass 2 with (chunks done, chunks, input faces), from one thread
  // at a time.
  std::function<void(std::size_t, std::size_t, std::uint64_t)> progress;
};

struct OutOfCoreSampling {
  std::optional<GaussSphere> gauss;  // the chosen orientation's sphere
  std::size_t chosen = 0;            // index into spheres
  std::vector<std::size_t> samples_per_orientation;
  std::vector<GlobalSample> samples;  // of the chosen orientation, ascending vertex id
  // The paper test: its candidate pairs along feature chains, and their digest
  // (candidate_pairs_digest, stream/stitch/paper_chains.h).
  std::size_t candidate_pairs = 0;
  std::uint64_t candidate_pairs_digest = 0;
  ChunkSamplingStats stats;           // of the chosen orientation
  std::uint64_t vertices = 0, faces = 0;
  std::size_t chunks = 0;
  std::uint64_t bytes_spilled = 0;
  double seconds_ingest = 0, seconds_partition = 0, seconds_sample = 0;
  double seconds_cleanup = 0;  // removing the temporary directory (the file system's writeback can stall it)
  PartitionSteps partition_steps;  // seconds_partition by step
  // The process's peak RSS when passes 0-1 had finished (getrusage), to tell which pass peaks.
  std::uint64_t peak_rss_after_partition = 0;
};

// Passes 0-2 for `gaussmesh sample --memory`: partition input_path ("-": stdin), then sample
// every chunk once for all orientations, keeping the one with the fewest samples (ties: the
// earliest). The paper test's samples need the stitch: it runs simplify's passes up to them
// (simplify_out_of_core with samples_only, stream/pipeline/out_of_core_simplify.h), once per orientation.
// Memory: the partition's budget; pass 2 holds `threads` chunks (the partition sizes them for it)
// plus the samples. Errors: kUsage for bad G options; the partition's (bad input, temp files,
// resources); kBadInput for a damaged chunk file or record. The temporary directory is gone when
// this returns.
format::Result<OutOfCoreSampling> sample_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                     const OutOfCoreSamplingOptions& options);

}  // namespace gaussmesh::stream
