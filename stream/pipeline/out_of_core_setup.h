// What both out-of-core pipelines (simplify, sample) do before their chunk passes: check the
// options, build the Gaussian spheres, partition the input into chunks sized for the sample
// pass, and copy the partition's figures into the result.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/mesh_reader.h"
#include "format/status.h"
#include "stream/core/gauss_sphere.h"
#include "stream/core/memory_budget.h"
#include "stream/core/process_memory.h"
#include "stream/partition/chunk_partition.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::stream {

// kUsage when an out-of-core run (`command` names it in the message) cannot take these options:
// no orientation, or 0 threads.
format::Status check_out_of_core_options(const char* command, const std::vector<GaussSphereOptions>& spheres,
                                         std::uint32_t threads);

// The Gaussian spheres of `options` (kUsage for bad options).
format::Result<std::vector<GaussSphere>> create_spheres(const std::vector<GaussSphereOptions>& options);

// Chunk size (faces) for the sample pass from the budget: the pass holds, per thread in flight,
// the decoded chunk and the sampler's arrays, which keep the capacity of the largest chunk seen.
// The process itself (binary, TBB, reader window, samples) takes a 20 MiB reserve; each target
// face takes 28 B per overlap ring and one more (112 B at the default 3 rings; smoothing adds
// rings, and the overlap grows with them). The per-face figure leaves slack over the measured
// growth of the peak, and fewer, larger chunks make the partition cheaper while the sample pass
// does not change (docs/benchmarks.md). At least 1,024 faces.
std::uint64_t sample_pass_chunk_faces(const MemoryBudget& budget, std::uint32_t threads, std::uint32_t rings = 3);

// The ingest and partition passes for the chunk passes: partition options' tmp dir and chunk
// size, the budget, the overlap the sampler's smoothing needs, chunks sized for `threads` in
// flight (sample_pass_chunk_faces, unless options.max_chunk_faces is set).
format::Result<Partition> partition_for_chunks(const std::string& input_path, const format::ReadOptions& read,
                                               const PartitionOptions& options, const MemoryBudget& budget,
                                               const SamplerOptions& sampler, std::uint32_t threads);

// Copies what the ingest and partition passes measured into an out-of-core result
// (OutOfCoreSampling or OutOfCoreSimplify: input counts, chunks, seconds) and notes the peak RSS
// after them.
template <class Result>
void record_partition(const Partition& partition, Result& out) {
  out.vertices = partition.vertices;
  out.faces = partition.faces;
  out.chunks = partition.chunks.size();
  out.seconds_ingest = partition.seconds_ingest;
  out.reordered = partition.reordered;
  out.welded_vertices = partition.welded_vertices;
  out.input_attributes = partition.input_attributes;
  out.attribute_spill = partition.attribute_spill;
  out.ignored_vertex_values = partition.ignored_vertex_values;
  out.input_warnings = partition.input_warnings;
  out.seconds_reorder = partition.seconds_reorder;
  out.seconds_partition = partition.seconds_partition;
  out.partition_steps = partition.steps;
  out.reorder_steps = partition.reorder_steps;
  out.peak_rss_after_partition = peak_rss();
}

}  // namespace gaussmesh::stream
