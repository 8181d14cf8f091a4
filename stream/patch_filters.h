// Patch-level steps of the sampler (paper §4 "Untriangulatable Patch Filtering" Fig. 6, "Noisy
// Sample Filtering" Figs. 9-10): patches, candidate adjacency along feature chains, the merge
// plan for untriangulatable patches, and the noisy-sample minimum cover. Inputs are explicit
// arrays and records so that the out-of-core stitch can run them over records later.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "stream/gauss_sphere.h"
#include "stream/mesh_adjacency.h"

namespace gaussmesh::stream {

inline constexpr std::uint32_t kNoPatch = 0xFFFFFFFFu;

struct Patches {
  std::vector<std::uint32_t> face_patch;   // per face
  std::vector<std::uint32_t> patch_label;  // per patch
  std::vector<std::uint32_t> patch_size;   // faces per patch
};

// Connected components of faces across manifold edges whose feature bit is clear, numbered in
// order of their lowest face. Collapsed faces are patches of their own.
Patches find_patches(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                     const std::vector<std::uint8_t>& feature);
// The same into `out`, reusing its arrays and the traversal stack (no allocation when warm).
void find_patches(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                  const std::vector<std::uint8_t>& feature, Patches& out, std::vector<std::uint32_t>& stack);

// Per patch: kNoPatch if its boundary carries >= 3 candidates (is_candidate[v] != 0) or it has
// no neighbour across a manifold feature edge; otherwise the neighbour it should join: the one
// sharing most feature edges with it, ties to the lowest patch id (Fig. 6 a, b). A patch never
// joins a patch that itself joins another in the same plan (so the plan can be applied at once;
// the caller repeats until the plan is empty).
std::vector<std::uint32_t> plan_untriangulatable_merges(format::MeshView mesh, const MeshAdjacency& adjacency,
                                                        const Patches& patches,
                                                        const std::vector<std::uint8_t>& feature,
                                                        const std::vector<std::uint8_t>& is_candidate);
// The same into `target`, reusing scratch across rounds and calls. O(F + V + P): candidates
// counted per patch from the candidates' stars, neighbours bucketed by patch.
struct MergePlanScratch {
  std::vector<std::uint32_t> candidate_count, bucket, cursor, neighbors, patch_list;
  std::vector<std::uint8_t> is_target;
};
void plan_untriangulatable_merges(format::MeshView mesh, const MeshAdjacency& adjacency, const Patches& patches,
                                  const std::vector<std::uint8_t>& feature,
                                  const std::vector<std::uint8_t>& is_candidate, std::vector<std::uint32_t>& target,
                                  MergePlanScratch& scratch);

// Pairs (a, b), a < b, of candidate vertices joined by a chain of feature edges through no
// other candidate (paper "Adjacent Samples"); sorted, unique. Chains are followed through
// vertices with exactly two incident feature edges.
std::vector<std::pair<std::uint32_t, std::uint32_t>> find_candidate_adjacency(
    format::MeshView mesh, const MeshAdjacency& adjacency, const std::vector<std::uint8_t>& feature,
    const std::vector<std::uint8_t>& is_candidate);

// One candidate as the noisy-sample filter sees it.
struct NoisyFilterInput {
  std::uint32_t vertex = 0;
  std::uint32_t gauss_vertex = 0xFFFFFFFFu;  // represented v_G, or none (then always kept)
  std::uint8_t characteristic = 0;
  std::uint8_t cover_mask = 0;  // which triangles around v_G its faces carry
};

// Noisy-sample filter. Returns keep flags parallel to candidates (sorted by vertex). Groups are
// the connected components of `adjacency` restricted to candidates with the same v_G. Rule 1:
// two adjacent candidates with different characteristics are both kept. Rule 2: in each
// connected same-characteristic subgroup, keep a minimum subset whose cover masks together
// cover what the whole subgroup covers (exhaustive up to 16 members, greedy beyond; ties to
// the subset with the lowest vertex ids).
std::vector<std::uint8_t> noisy_sample_filter(const std::vector<NoisyFilterInput>& candidates,
                                              const std::vector<std::pair<std::uint32_t, std::uint32_t>>& adjacency);

}  // namespace gaussmesh::stream
