// The sample pass on one chunk: steps 1-2 of the sampler for the vertices it owns. See
// chunk_sampler.h.
#include "stream/sampling/chunk_sampler.h"

namespace gaussmesh::stream {

void ChunkSamplingStats::add(const ChunkSamplingStats& o) {
  owned_vertices += o.owned_vertices;
  owned_faces += o.owned_faces;
  chunk_faces += o.chunk_faces;
  degenerate_faces += o.degenerate_faces;
  unlabelled_faces += o.unlabelled_faces;
  candidates_initial += o.candidates_initial;
  exact_samples += o.exact_samples;
}

format::Status sample_chunk(const ChunkMesh& chunk, const GaussSphere& gauss, const SamplerOptions& options,
                            ChunkSamplerWorkspace& ws, std::vector<GlobalSample>& samples, ChunkSamplingStats& stats) {
  const bool exact = options.sample_test == SampleTest::kExact;
  const format::MeshView mesh = chunk.view();
  GM_RETURN_IF_ERROR(build_mesh_adjacency(mesh, ws.adjacency));
  compute_face_normals(mesh, ws.adjacency, options.smooth_iterations, ws.normals, ws.area, ws.smoothed);
  compute_face_labels(ws.normals, gauss, ws.labels);
  compute_feature_edges(ws.adjacency, ws.labels, ws.feature);
  ws.owned.clear();
  for (std::uint32_t v = 0; v < chunk.owned_vertex.size(); ++v) {
    if (chunk.owned_vertex[v]) ws.owned.push_back(v);
  }
  ws.records.clear();
  evaluate_vertex_list(mesh, ws.adjacency, ws.normals, ws.labels, ws.feature, gauss, exact, ws.owned, ws.records);
  ChunkSamplingStats s;
  s.owned_vertices = ws.owned.size();
  s.chunk_faces = chunk.triangles.size();
  for (std::size_t f = 0; f < chunk.triangles.size(); ++f) {
    if (!chunk.owned_face[f]) continue;
    ++s.owned_faces;
    s.degenerate_faces += ws.normals.degenerate[f];
    s.unlabelled_faces += ws.labels[f] == kNoLabel;
  }
  for (const VertexRecord& r : ws.records) {
    s.candidates_initial += r.is_candidate;
    if (!exact || !r.is_exact_sample) continue;
    ++s.exact_samples;
    samples.push_back({chunk.global_vertex[r.vertex], chunk.positions[r.vertex], r.exact_gauss_vertex,
                       r.exact_characteristic});
  }
  stats.add(s);
  return format::Status();
}

}  // namespace gaussmesh::stream
