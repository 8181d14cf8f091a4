// Patch-level steps of the sampler (paper §4 "Untriangulatable Patch Filtering" Fig. 6, "Noisy
// Sample Filtering" Figs. 9-10): patches, candidate adjacency along feature chains, the merge
// plan for untriangulatable patches, and the noisy-sample minimum cover. Inputs are explicit
// arrays and records so that the out-of-core stitch can run them over records later.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <utility>
#include <vector>

#include "stream/core/gauss_sphere.h"
#include "stream/core/mesh_adjacency.h"

namespace gaussmesh::stream {

inline constexpr std::uint32_t kNoPatch = 0xFFFFFFFFu;

struct Patches {
  std::vector<std::uint32_t> face_patch;   // per face
  std::vector<std::uint32_t> patch_label;  // per patch
  std::vector<std::uint32_t> patch_size;   // faces per patch
};

// Connected components of faces across manifold edges whose feature bit is clear. Collapsed
// faces are patches of their own. Numbered in order of their first face, faces ordered by
// (face_key[f], f) — face_order_keys gives the keys that make the numbering, and so every
// choice made in patch order, independent of the input's order (stream/core/canonical_order.h) —
// or by id alone when face_key is empty.
Patches find_patches(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                     const std::vector<std::uint8_t>& feature, std::span<const std::uint64_t> face_key = {});
// The same into `out`, reusing its arrays and the traversal stack (no allocation when warm).
void find_patches(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                  const std::vector<std::uint8_t>& feature, Patches& out, std::vector<std::uint32_t>& stack,
                  std::span<const std::uint64_t> face_key = {});
// face_order_key of every face of mesh, into keys.
void face_order_keys(format::MeshView mesh, std::vector<std::uint64_t>& keys);

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

// ---- The untriangulatable-patch merge on the patch graph --------------------------------------
//
// plan_untriangulatable_merges applied in rounds until its plan is empty (at most
// kMaxMergeRounds rounds), with the same decisions, but on the patch graph instead of the mesh:
// the patches, their adjacency and the candidates' patch lists are built once after the first
// find_patches, and a round costs what it merges (the small patches it plans for, the lists of
// the patches it unites, the candidates it re-evaluates) instead of O(faces). The inputs are
// explicit records, not the mesh, so that the out-of-core stitch can feed them from per-chunk
// records; build_patch_graph is the in-core builder (sample_mesh).

inline constexpr int kMaxMergeRounds = 64;

struct PatchNeighbor {
  std::uint32_t patch = 0;  // the neighbour
  std::uint32_t edges = 0;  // manifold feature edges shared with it (>= 1)
};

struct PatchGraphInput {
  // Per patch. Ids must be numbered in increasing order of the patch's lowest face, as
  // find_patches numbers them: the plan visits patches and breaks ties in id order, and merged
  // patches are numbered by their lowest id. (An out-of-core stitch numbers its joined patches
  // by their lowest global face id.)
  std::vector<std::uint32_t> patch_label;
  std::vector<std::uint32_t> patch_size;  // faces (only added up, for the result)
  // Patch p's neighbours across manifold feature edges, distinct, with how many edges they
  // share: neighbors[neighbor_offsets[p] .. neighbor_offsets[p + 1]). Every pair is listed from
  // both sides with the same count (patch_neighbors_from_pairs builds this from a pair list).
  std::vector<std::uint32_t> neighbor_offsets;  // patches + 1 entries
  std::vector<PatchNeighbor> neighbors;
  // The candidates (vertices with >= 3 incident feature edges, in any fixed order), each as the
  // list of *distinct* patches it counts for: candidate k's are
  // candidate_patches[candidate_offsets[k] .. candidate_offsets[k + 1]), the patches of its
  // star's faces plus those of the collapsed faces holding it (a collapsed face is a patch of
  // its own, in no star; its candidate vertices count for it, as in
  // plan_untriangulatable_merges). Non-candidates are not listed: merges only remove feature
  // edges, so a non-candidate never becomes one.
  std::vector<std::uint32_t> candidate_offsets;  // candidates + 1 entries
  std::vector<std::uint32_t> candidate_patches;
};

struct PatchMergeResult {
  // Per input patch: its merged patch, numbered 0.. in order of the lowest input id (= lowest
  // face): find_patches' numbering of the merged labels.
  std::vector<std::uint32_t> patch_of;
  std::vector<std::uint32_t> patch_label, patch_size;  // per merged patch
  // Pairs (p, q), p < q, of merged patches sharing a manifold feature edge; sorted.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> adjacency;
  std::vector<std::uint8_t> is_candidate;  // per input candidate: still one after the merges
  std::size_t merged_patches = 0;          // patches merged away, summed over rounds
  std::size_t rounds = 0;                  // rounds that merged
};

// Lists stored as circular chains of segments of one pool, each named by its last segment:
// moving a list to the end of another is O(1).
template <typename T>
struct ChainedLists {
  static constexpr std::uint32_t kEnd = 0xFFFFFFFFu;
  struct Segment {
    std::uint32_t begin, end, next;  // items pool[begin, end); next: the following segment (the last: the first)
  };
  std::vector<T> pool;
  std::vector<Segment> segments;
  std::vector<std::uint32_t> last;    // per list: its last segment, kEnd when empty
  std::vector<std::uint32_t> length;  // per list: items (when kept)
};

// State of the merge on the patch graph (reusable across calls: no allocation when warm).
// Current patches are union-find sets of input patches named by their lowest input id; each
// keeps a chained list of (neighbour, shared edges) and of the candidates counting for it, and
// how many of those are live. A round visits only the patches with < 3 live candidates (in id
// order), unites groups small list into large, and re-evaluates only the candidates counting
// for a patch that left. Pools are indexed by 32-bit ids (< 2^32 neighbour entries).
class PatchMergeGraph {
 public:
  // Re-evaluation of candidates after a round, supplied by the caller. touched: the candidates
  // (ascending ids) that count for a patch which merged away in this round (for the mesh: whose
  // star meets a relabelled face); the callback sets still_candidate (sized like touched, all
  // 1 on entry) to 0 where the candidate lost its candidacy (< 3 feature edges now). During the
  // call, label(p) is the label of input patch p after the round, and two input patches are one
  // merged patch iff patch() agrees; those compress paths (one thread only), current_label()
  // and current_patch() only read (several threads may call them). In core, sample_mesh
  // re-evaluates from the mesh's stars (labels from the graph, normals and positions from the
  // mesh); out of core, the stitch has to carry each candidate's star (patch ids in fan order,
  // and for the paper test the normals and neighbour positions) in its records.
  using Reevaluate = std::function<void(PatchMergeGraph& graph, std::span<const std::uint32_t> touched,
                                        std::vector<std::uint8_t>& still_candidate)>;

  // Takes the input's patches, adjacency and candidates. O(P + adjacency + candidate lists).
  // `input` must outlive the calls below up to finish().
  void reset(const PatchGraphInput& input);
  // The same, but takes input.neighbors by swapping it with the graph's own buffer instead of
  // copying it (input.neighbors is left unspecified; reusable as a buffer).
  void reset_taking_neighbors(PatchGraphInput& input);
  // One round: the plan of plan_untriangulatable_merges on the current patches, applied: a
  // merged patch takes its target's label, then every two adjacent patches with equal labels
  // become one (a leaving patch may touch other patches of its target's label); shared-edge
  // counts add up; candidates are re-evaluated through `reevaluate`. Returns the number of
  // patches merged away (0: the plan was empty, nothing changed).
  std::size_t round(const Reevaluate& reevaluate);
  // Rounds until the plan is empty or max_rounds rounds merged. Returns the rounds that merged.
  std::size_t merge(const Reevaluate& reevaluate, int max_rounds = kMaxMergeRounds);
  // The merged patch that input patch p belongs to, named by its lowest input id.
  std::uint32_t patch(std::uint32_t p) {
    while (parent_[p] != p) p = parent_[p] = parent_[parent_[p]];
    return p;
  }
  std::uint32_t label(std::uint32_t p) { return label_[patch(p)]; }
  // The same without path compression (const, thread-safe between rounds).
  std::uint32_t current_patch(std::uint32_t p) const {
    while (parent_[p] != p) p = parent_[p];
    return p;
  }
  std::uint32_t current_label(std::uint32_t p) const { return label_[current_patch(p)]; }
  bool is_candidate(std::uint32_t candidate) const { return !dead_[candidate]; }
  // Live candidates counting for current patch p (p == patch(p)).
  std::uint32_t candidate_count(std::uint32_t p) const { return count_[p]; }
  std::size_t merged_patches() const { return merged_; }
  std::size_t rounds() const { return rounds_; }
  // The merged patches, their labels, sizes and adjacency, the surviving candidates. O(P +
  // adjacency lists).
  void finish(PatchMergeResult& out);

 private:
  using Neighbor = PatchNeighbor;
  // Aggregates p's neighbour list by current patch (dropping p itself) and stores it back;
  // returns the neighbour sharing most edges (ties: lowest id), or kNoPatch if none.
  std::uint32_t compact_neighbors(std::uint32_t p);
  void reset_lists(const PatchGraphInput& input);  // everything but neighbors_.pool
  bool candidate_touches(std::uint32_t candidate, std::uint32_t patch);
  std::uint32_t next_stamp();

  const PatchGraphInput* input_ = nullptr;
  std::vector<std::uint32_t> parent_, label_, count_, target_, slot_, member_next_, stamp_;
  std::vector<std::uint8_t> flags_, dead_;
  ChainedLists<Neighbor> neighbors_;      // per patch: (patch, shared edges), possibly stale ids
  ChainedLists<std::uint32_t> members_;   // per patch: candidates counting for it, possibly dead
  std::vector<std::uint32_t> small_, next_small_, leaving_, targets_, touched_, involved_, extras_, roots_;
  std::vector<Neighbor> scratch_;
  std::vector<std::uint8_t> still_;
  std::uint32_t stamp_counter_ = 0;
  std::size_t merged_ = 0, rounds_ = 0;
};

// Fills input.neighbor_offsets / neighbors (for input.patch_label.size() patches) from
// unordered pairs (a, b, shared edges), each pair once, a != b.
struct PatchPair {
  std::uint32_t a = 0, b = 0, edges = 0;
};
void patch_neighbors_from_pairs(std::span<const PatchPair> pairs, PatchGraphInput& input);

// The in-core builder of the merge's input, from the patches of the first find_patches:
// adjacency counted over manifold feature edges, candidate k = candidates[k] (ascending
// vertex ids) with the distinct patches of its star and of the collapsed faces holding it.
// O(F + candidates' stars).
struct PatchGraphBuildScratch {
  std::vector<std::uint32_t> slot, bucket, entries;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> collapsed;  // (vertex, patch)
};
void build_patch_graph(format::MeshView mesh, const MeshAdjacency& adjacency, const Patches& patches,
                       const std::vector<std::uint8_t>& feature, std::span<const std::uint32_t> candidates,
                       PatchGraphInput& out, PatchGraphBuildScratch& scratch);

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
