// The sample pass's work on one chunk (docs/pipeline.md): the sampler's local functions
// (stream/sampling/sampler.h, steps 1-2) on a chunk loaded from disk, for the vertices it owns.
// The exact sample test is a per-vertex decision, so a chunk's samples are the whole mesh's at
// the vertices it owns, for any chunking (tests/stream/locality_test.cpp). The pipelines that
// run it over every chunk are in stream/pipeline/ (out_of_core_sample.h, out_of_core_simplify.h).
#pragma once

#include <cstdint>
#include <vector>

#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/core/gauss_sphere.h"
#include "stream/partition/chunk_partition.h"
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

}  // namespace gaussmesh::stream
