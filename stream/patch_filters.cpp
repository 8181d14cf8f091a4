// Patch-level steps of the sampler (paper §4, "Untriangulatable Patch Filtering" Fig. 6 and
// "Noisy Sample Filtering" Figs. 9-10; DESIGN §1 "Per patch").
#include "stream/patch_filters.h"

#include <algorithm>
#include <bit>
#include <numeric>

namespace gaussmesh::stream {
namespace {

struct DisjointSets {
  std::vector<std::uint32_t> parent;
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace

void find_patches(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                  const std::vector<std::uint8_t>& feature, Patches& p, std::vector<std::uint32_t>& stack) {
  const std::size_t nf = labels.size();
  p.face_patch.assign(nf, kNoPatch);
  p.patch_label.clear();
  p.patch_size.clear();
  stack.clear();
  std::uint32_t* face_patch = p.face_patch.data();
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  const std::uint8_t* bits = feature.data();
  for (std::size_t seed = 0; seed < nf; ++seed) {
    if (face_patch[seed] != kNoPatch) continue;
    const std::uint32_t id = static_cast<std::uint32_t>(p.patch_label.size());
    p.patch_label.push_back(labels[seed]);
    face_patch[seed] = id;
    // A face whose three edges are features is a patch of its own (common in noisy regions).
    if (bits[seed] == 7) {
      p.patch_size.push_back(1);
      continue;
    }
    std::uint32_t size = 0;
    stack.push_back(static_cast<std::uint32_t>(seed));
    while (!stack.empty()) {
      const std::uint32_t f = stack.back();
      stack.pop_back();
      ++size;
      for (int i = 0; i < 3; ++i) {
        if (bits[f] >> i & 1) continue;
        const std::uint32_t g = nb[3 * f + i];
        if (g == MeshAdjacency::kNoFace || face_patch[g] != kNoPatch) continue;
        face_patch[g] = id;
        stack.push_back(g);
      }
    }
    p.patch_size.push_back(size);
  }
}

Patches find_patches(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                     const std::vector<std::uint8_t>& feature) {
  Patches p;
  std::vector<std::uint32_t> stack;
  find_patches(adjacency, labels, feature, p, stack);
  return p;
}

void plan_untriangulatable_merges(format::MeshView mesh, const MeshAdjacency& adjacency, const Patches& patches,
                                  const std::vector<std::uint8_t>& feature,
                                  const std::vector<std::uint8_t>& is_candidate, std::vector<std::uint32_t>& target,
                                  MergePlanScratch& s) {
  const std::size_t np = patches.patch_label.size();
  const std::size_t nf = patches.face_patch.size();
  const std::size_t nv = adjacency.vertex_count();
  const std::uint32_t* face_patch = patches.face_patch.data();
  // Distinct candidates per patch: a candidate's faces are its star (plus collapsed faces,
  // which are patches of their own and in no star).
  s.candidate_count.assign(np, 0);
  std::uint32_t* candidate_count = s.candidate_count.data();
  std::uint32_t seen[64];
  for (std::size_t v = 0; v < nv; ++v) {
    if (!is_candidate[v]) continue;
    const std::uint32_t begin = adjacency.star_begin(static_cast<std::uint32_t>(v)),
                        end = adjacency.star_end(static_cast<std::uint32_t>(v));
    if (end - begin <= 64) {
      std::uint32_t n = 0;
      for (std::uint32_t k = begin; k < end; ++k) {
        const std::uint32_t p = face_patch[adjacency.vertex_corners[k] / 3];
        bool dup = false;
        for (std::uint32_t j = 0; j < n && !dup; ++j) dup = seen[j] == p;
        if (!dup) {
          seen[n++] = p;
          ++candidate_count[p];
        }
      }
    } else {
      s.patch_list.clear();
      for (std::uint32_t k = begin; k < end; ++k) s.patch_list.push_back(face_patch[adjacency.vertex_corners[k] / 3]);
      std::sort(s.patch_list.begin(), s.patch_list.end());
      s.patch_list.erase(std::unique(s.patch_list.begin(), s.patch_list.end()), s.patch_list.end());
      for (std::uint32_t p : s.patch_list) ++candidate_count[p];
    }
  }
  if (adjacency.collapsed_faces > 0) {
    for (std::size_t f = 0; f < nf; ++f) {
      const auto& t = mesh.triangles[f];
      if (!(t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2])) continue;
      std::uint32_t n = 0;
      for (int i = 0; i < 3; ++i) {
        bool dup = false;
        for (int j = 0; j < i; ++j) dup = dup || t.v[j] == t.v[i];
        n += !dup && is_candidate[t.v[i]];
      }
      candidate_count[face_patch[f]] += n;
    }
  }
  // Feature edges from each patch with < 3 candidates to each neighbour, bucketed by patch
  // (counting sort: the patches are visited in id order below).
  s.bucket.assign(np + 1, 0);
  std::uint32_t* bucket = s.bucket.data();
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  const std::uint8_t* bits = feature.data();
  for (std::size_t f = 0; f < nf; ++f) {
    if (!bits[f]) continue;
    const std::uint32_t p = face_patch[f];
    if (candidate_count[p] >= 3) continue;
    for (int i = 0; i < 3; ++i) {
      if (!(bits[f] >> i & 1)) continue;
      const std::uint32_t g = nb[3 * f + i];
      if (g != MeshAdjacency::kNoFace && face_patch[g] != p) ++bucket[p + 1];
    }
  }
  for (std::size_t p = 0; p < np; ++p) bucket[p + 1] += bucket[p];
  s.neighbors.resize(bucket[np]);
  {
    s.cursor.assign(bucket, bucket + np);
    std::uint32_t* cursor = s.cursor.data();
    std::uint32_t* out = s.neighbors.data();
    for (std::size_t f = 0; f < nf; ++f) {
      if (!bits[f]) continue;
      const std::uint32_t p = face_patch[f];
      if (candidate_count[p] >= 3) continue;
      for (int i = 0; i < 3; ++i) {
        if (!(bits[f] >> i & 1)) continue;
        const std::uint32_t g = nb[3 * f + i];
        if (g != MeshAdjacency::kNoFace && face_patch[g] != p) out[cursor[p]++] = face_patch[g];
      }
    }
  }
  target.assign(np, kNoPatch);
  s.is_target.assign(np, 0);
  for (std::size_t p = 0; p < np; ++p) {
    if (bucket[p] == bucket[p + 1]) continue;
    // The neighbour sharing most feature edges, ties to the lowest id.
    std::uint32_t* begin = s.neighbors.data() + bucket[p];
    std::uint32_t* end = s.neighbors.data() + bucket[p + 1];
    std::sort(begin, end);
    std::uint32_t best = kNoPatch, best_count = 0;
    for (std::uint32_t* k = begin; k < end;) {
      std::uint32_t* run = k;
      while (run < end && *run == *k) ++run;
      const std::uint32_t count = static_cast<std::uint32_t>(run - k);
      if (count > best_count) {
        best = *k;
        best_count = count;
      }
      k = run;
    }
    // Apply the plan in patch order: a patch that already absorbs another this round, or
    // whose chosen neighbour is itself leaving, waits for the next round.
    if (s.is_target[p] || target[best] != kNoPatch) continue;
    target[p] = best;
    s.is_target[best] = 1;
  }
}

std::vector<std::uint32_t> plan_untriangulatable_merges(format::MeshView mesh, const MeshAdjacency& adjacency,
                                                        const Patches& patches,
                                                        const std::vector<std::uint8_t>& feature,
                                                        const std::vector<std::uint8_t>& is_candidate) {
  std::vector<std::uint32_t> target;
  MergePlanScratch scratch;
  plan_untriangulatable_merges(mesh, adjacency, patches, feature, is_candidate, target, scratch);
  return target;
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> find_candidate_adjacency(
    format::MeshView mesh, const MeshAdjacency& adjacency, const std::vector<std::uint8_t>& feature,
    const std::vector<std::uint8_t>& is_candidate) {
  const auto* tris = mesh.triangles.data();
  // Other ends of the feature edges at v (one entry per fan side).
  auto feature_neighbors = [&](std::uint32_t v, std::vector<std::uint32_t>& out) {
    out.clear();
    for (std::uint32_t s = adjacency.star_begin(v); s < adjacency.star_end(v); ++s) {
      const std::uint32_t c = adjacency.vertex_corners[s];
      const std::uint32_t f = c / 3, i = c % 3;
      if (feature[f] >> i & 1) out.push_back(tris[f].v[(i + 1) % 3]);
      if (adjacency.edge_neighbor[3 * f + (i + 2) % 3] == MeshAdjacency::kNoFace) out.push_back(tris[f].v[(i + 2) % 3]);
    }
  };
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  std::vector<std::uint32_t> around, step;
  const std::size_t nv = adjacency.vertex_count();
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (!is_candidate[v]) continue;
    feature_neighbors(v, around);
    for (std::uint32_t first : around) {
      std::uint32_t prev = v, cur = first;
      for (std::size_t steps = 0; steps <= nv; ++steps) {
        if (is_candidate[cur]) {
          if (cur != v) pairs.emplace_back(std::min(v, cur), std::max(v, cur));
          break;
        }
        feature_neighbors(cur, step);
        if (step.size() != 2) break;  // the chain ends without reaching a candidate
        const std::uint32_t next = step[0] == prev ? step[1] : step[0];
        prev = cur;
        cur = next;
      }
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

std::vector<std::uint8_t> noisy_sample_filter(const std::vector<NoisyFilterInput>& candidates,
                                              const std::vector<std::pair<std::uint32_t, std::uint32_t>>& adjacency) {
  const std::size_t n = candidates.size();
  std::vector<std::uint8_t> keep(n, 0);
  auto index_of = [&](std::uint32_t vertex) {
    auto it = std::lower_bound(candidates.begin(), candidates.end(), vertex,
                               [](const NoisyFilterInput& c, std::uint32_t v) { return c.vertex < v; });
    return it != candidates.end() && it->vertex == vertex ? static_cast<std::size_t>(it - candidates.begin()) : n;
  };
  DisjointSets same(n);  // same v_G and same characteristic, adjacent
  std::vector<std::uint8_t> grouped(n, 0);
  for (const auto& [a, b] : adjacency) {
    const std::size_t i = index_of(a), j = index_of(b);
    if (i == n || j == n) continue;
    const auto& ci = candidates[i];
    const auto& cj = candidates[j];
    if (ci.gauss_vertex == 0xFFFFFFFFu || ci.gauss_vertex != cj.gauss_vertex) continue;
    grouped[i] = grouped[j] = 1;
    if (ci.characteristic != cj.characteristic) {
      keep[i] = keep[j] = 1;  // rule 1
    } else {
      same.unite(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
    }
  }
  // Candidates in no group (no adjacent candidate of the same v_G, or no v_G) are kept.
  std::vector<std::vector<std::uint32_t>> members(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!grouped[i]) keep[i] = 1;
    members[same.find(static_cast<std::uint32_t>(i))].push_back(static_cast<std::uint32_t>(i));
  }
  for (const auto& group : members) {
    if (group.size() < 2) continue;  // singletons were kept above or by rule 1
    std::uint8_t want = 0;
    for (std::uint32_t i : group) want |= candidates[i].cover_mask;
    const std::size_t m = group.size();  // members are in vertex order (ascending i)
    std::vector<std::uint8_t> chosen(m, 0);
    if (m <= 16) {
      // Subsets in increasing size, then increasing bit pattern: the first cover found is a
      // minimum one, preferring low vertex ids.
      int best_bits = 64;
      std::uint32_t best_subset = 0;
      for (std::uint32_t subset = 1; subset < (1u << m); ++subset) {
        const int bits = std::popcount(subset);
        if (bits >= best_bits) continue;
        std::uint8_t got = 0;
        for (std::size_t k = 0; k < m; ++k)
          if (subset >> k & 1) got |= candidates[group[k]].cover_mask;
        if (got == want) {
          best_bits = bits;
          best_subset = subset;
        }
      }
      for (std::size_t k = 0; k < m; ++k) chosen[k] = best_subset >> k & 1;
    } else {
      std::uint8_t got = 0;
      while (got != want) {
        std::size_t best = 0;
        int best_gain = 0;
        for (std::size_t k = 0; k < m; ++k) {
          const int gain = std::popcount(static_cast<unsigned>(candidates[group[k]].cover_mask & ~got));
          if (gain > best_gain) {
            best_gain = gain;
            best = k;
          }
        }
        if (best_gain == 0) break;
        got |= candidates[group[best]].cover_mask;
        chosen[best] = 1;
      }
    }
    if (std::find(chosen.begin(), chosen.end(), 1) == chosen.end()) chosen[0] = 1;  // keep one
    for (std::size_t k = 0; k < m; ++k)
      if (chosen[k]) keep[group[k]] = 1;
  }
  return keep;
}

}  // namespace gaussmesh::stream
