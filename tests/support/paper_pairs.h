// The in-core paper test's candidate pairs, for tests that check the out-of-core ones.
#pragma once

#include <cstddef>
#include <cstdint>

#include "stream/core/gauss_sphere.h"
#include "stream/core/mesh.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::stream {

// The in-core paper test's candidate pairs (find_candidate_adjacency under the merged labels)
// as candidate_pairs_digest, their count in *count: out of core must find the same pairs, not
// only the same samples (on the fixtures, pairs along chains that cross chunks rarely change
// which samples survive). On an error of the in-core run: 0 and a count of SIZE_MAX, which no
// out-of-core run matches.
std::uint64_t in_core_pairs_digest(const Mesh& mesh, const GaussSphereOptions& sphere, const SamplerOptions& sampler,
                                   std::size_t* count);

}  // namespace gaussmesh::stream
