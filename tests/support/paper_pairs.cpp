// See paper_pairs.h.
#include "tests/support/paper_pairs.h"

#include <cstdint>
#include <vector>

#include "stream/core/mesh_adjacency.h"
#include "stream/stitch/paper_chains.h"
#include "stream/sampling/patch_filters.h"

namespace gaussmesh::stream {

std::uint64_t in_core_pairs_digest(const Mesh& mesh, const GaussSphereOptions& sphere, const SamplerOptions& sampler,
                                   std::size_t* count) {
  *count = SIZE_MAX;
  auto gauss = GaussSphere::create(sphere);
  if (!gauss.is_ok()) return 0;
  auto sampled = sample_mesh(mesh.view(), *gauss, sampler);
  if (!sampled.is_ok()) return 0;
  auto adjacency = build_mesh_adjacency(mesh.view());
  if (!adjacency.is_ok()) return 0;
  std::vector<std::uint8_t> is_candidate(mesh.positions.size(), 0);
  for (const VertexRecord& r : sampled->candidates) is_candidate[r.vertex] = 1;
  const auto pairs = find_candidate_adjacency(mesh.view(), *adjacency, sampled->face_feature, is_candidate);
  *count = pairs.size();
  return candidate_pairs_digest(pairs);
}

}  // namespace gaussmesh::stream
