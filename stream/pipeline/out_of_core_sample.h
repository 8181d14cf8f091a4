// `gaussmesh sample --memory`: the out-of-core sampling pipeline (docs/pipeline.md). The
// ingest and partition passes write the input as chunks; the sample pass loads every chunk,
// samples the vertices it owns (stream/sampling/chunk_sampler.h) and releases it, chunks in
// parallel in bounded memory. The exact sample test is a per-vertex decision, so the samples
// equal the in-core run's for any chunking. The paper test's patch-level filters (the
// untriangulatable merge, the noisy filter) need the stitch of patch pieces and candidate chains
// across chunks: for it, sample_out_of_core runs simplify's passes up to the samples.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "format/mesh_reader.h"
#include "format/status.h"
#include "stream/core/gauss_sphere.h"
#include "stream/core/memory_budget.h"
#include "stream/partition/chunk_partition.h"
#include "stream/sampling/chunk_sampler.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::stream {

struct OutOfCoreSamplingOptions {
  PartitionOptions partition;  // tmp dir, chunk size; its memory, rings and threads follow from the fields below
  MemoryBudget memory{PartitionOptions{}.memory_bytes};  // --memory: the working set every pass shares
  std::uint32_t threads = 1;   // chunks in flight (--threads)
  std::vector<GaussSphereOptions> spheres = {GaussSphereOptions{}};  // orientations to try
  SamplerOptions sampler;
  // Called after each chunk of the sample pass with (chunks done, chunks, input faces), from one
  // thread at a time.
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
  bool reordered = false;  // the input was renumbered first (PartitionOptions::reorder_scattered)
  std::uint64_t welded_vertices = 0;  // welded away by it (vertices counts the rest)
  format::AttributeKinds input_attributes;                // Partition's
  std::shared_ptr<VertexAttributeSpill> attribute_spill;  // Partition's
  std::vector<std::string> ignored_vertex_values;    // Partition's
  std::vector<std::string> input_warnings;           // Partition's
  double seconds_reorder = 0;
  double seconds_ingest = 0, seconds_partition = 0, seconds_sample = 0;
  double seconds_cleanup = 0;  // removing the temporary directory (the file system's writeback can stall it)
  PartitionSteps partition_steps;  // seconds_partition by step
  ReorderSteps reorder_steps;      // seconds_reorder by step
  // The process's peak RSS when the partition pass had finished (getrusage), to tell which pass
  // peaks.
  std::uint64_t peak_rss_after_partition = 0;
};

// The ingest, partition and sample passes: partition input_path ("-": stdin), then sample every
// chunk once for all orientations, keeping the one with the fewest samples (ties: the earliest).
// The paper test's samples need the stitch: it runs simplify's passes up to them
// (simplify_out_of_core with samples_only, stream/pipeline/out_of_core_simplify.h), once per
// orientation. Memory: options.memory; the sample pass holds `threads` chunks (the partition
// sizes them for it) plus the samples. Errors: kUsage for bad G options; the partition's (bad
// input, temp files, resources); kBadInput for a damaged chunk file or record. The temporary
// directory is gone when this returns.
format::Result<OutOfCoreSampling> sample_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                     const OutOfCoreSamplingOptions& options);

}  // namespace gaussmesh::stream
