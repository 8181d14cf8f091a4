// Patch-level steps of the sampler (paper §4, "Untriangulatable Patch Filtering" Fig. 6 and
// "Noisy Sample Filtering" Figs. 9-10): the steps that need a traversal beyond the 1-ring.
#include "stream/sampling/patch_filters.h"
#include "stream/core/canonical_order.h"
#include "stream/core/disjoint_sets.h"

#include <algorithm>
#include <cassert>
#include <bit>
#include <numeric>

namespace gaussmesh::stream {

void face_order_keys(format::MeshView mesh, std::vector<std::uint64_t>& keys) {
  std::vector<std::uint64_t> vertex(mesh.positions.size());
  for (std::size_t v = 0; v < vertex.size(); ++v) vertex[v] = position_hash(mesh.positions[v]);
  keys.resize(mesh.triangles.size());
  for (std::size_t f = 0; f < keys.size(); ++f) {
    const auto& t = mesh.triangles[f];
    keys[f] = face_order_key(vertex[t.v[0]], vertex[t.v[1]], vertex[t.v[2]]);
  }
}

namespace {

// Patches renumbered in order of their first face by (face_key, face id).
void number_by_key(std::span<const std::uint64_t> face_key, Patches& p, std::vector<std::uint32_t>& scratch) {
  const std::size_t np = p.patch_label.size();
  std::vector<std::pair<std::uint64_t, std::uint32_t>> first(np, {~std::uint64_t{0}, ~std::uint32_t{0}});
  for (std::uint32_t f = 0; f < p.face_patch.size(); ++f) {
    auto& best = first[p.face_patch[f]];
    best = std::min(best, std::pair(face_key[f], f));
  }
  std::vector<std::uint32_t>& order = scratch;
  order.resize(np);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return first[a] < first[b]; });
  std::vector<std::uint32_t> rank(np), label(np), size(np);
  for (std::uint32_t k = 0; k < np; ++k) {
    rank[order[k]] = k;
    label[k] = p.patch_label[order[k]];
    size[k] = p.patch_size[order[k]];
  }
  for (std::uint32_t& q : p.face_patch) q = rank[q];
  p.patch_label.swap(label);
  p.patch_size.swap(size);
}

}  // namespace

void find_patches(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                  const std::vector<std::uint8_t>& feature, Patches& p, std::vector<std::uint32_t>& stack,
                  std::span<const std::uint64_t> face_key) {
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
  if (!face_key.empty()) number_by_key(face_key, p, stack);
}

Patches find_patches(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                     const std::vector<std::uint8_t>& feature, std::span<const std::uint64_t> face_key) {
  Patches p;
  std::vector<std::uint32_t> stack;
  find_patches(adjacency, labels, feature, p, stack, face_key);
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

// ---- The untriangulatable-patch merge on the patch graph --------------------------------------

namespace {

template <typename T>
constexpr std::uint32_t kEnd = ChainedLists<T>::kEnd;

// A list is a circular chain of segments named by its last one (whose next is the first), so
// that appending a segment or a whole list is O(1) with one index per list. `length` is kept
// only when it was sized (the candidate lists: small-to-large merging needs it).

// Lists l = pool[offsets[l] .. offsets[l + 1]), the pool already filled: one segment per list.
template <typename T>
void init_chains(ChainedLists<T>& c, const std::vector<std::uint32_t>& offsets, bool count_length) {
  const std::size_t n = offsets.size() - 1;
  c.segments.resize(n);
  c.last.resize(n);
  c.length.resize(count_length ? n : 0);
  for (std::size_t l = 0; l < n; ++l) {
    const auto id = static_cast<std::uint32_t>(l);
    c.segments[l] = {offsets[l], offsets[l + 1], id};
    c.last[l] = offsets[l] == offsets[l + 1] ? kEnd<T> : id;
    if (count_length) c.length[l] = offsets[l + 1] - offsets[l];
  }
}

template <typename T>
void clear_list(ChainedLists<T>& c, std::uint32_t l) {
  c.last[l] = kEnd<T>;
  if (!c.length.empty()) c.length[l] = 0;
}

// Appends pool[begin, end) to list l as a new segment.
template <typename T>
void add_segment(ChainedLists<T>& c, std::uint32_t l, std::uint32_t begin, std::uint32_t end) {
  if (begin == end) return;
  const auto s = static_cast<std::uint32_t>(c.segments.size());
  const std::uint32_t last = c.last[l];
  c.segments.push_back({begin, end, last == kEnd<T> ? s : c.segments[last].next});
  if (last != kEnd<T>) c.segments[last].next = s;
  c.last[l] = s;
  if (!c.length.empty()) c.length[l] += end - begin;
}

// Moves list src to the end of list dst; src becomes empty. O(1).
template <typename T>
void splice(ChainedLists<T>& c, std::uint32_t dst, std::uint32_t src) {
  const std::uint32_t a = c.last[src], b = c.last[dst];
  if (a == kEnd<T>) return;
  if (b != kEnd<T>) std::swap(c.segments[a].next, c.segments[b].next);  // b -> first of src, a -> first of dst
  c.last[dst] = a;
  if (!c.length.empty()) c.length[dst] += c.length[src];
  clear_list(c, src);
}

template <typename T, typename F>
void for_each_item(const ChainedLists<T>& c, std::uint32_t l, F&& f) {
  const std::uint32_t last = c.last[l];
  if (last == kEnd<T>) return;
  for (std::uint32_t s = c.segments[last].next;; s = c.segments[s].next) {
    const auto& seg = c.segments[s];
    for (std::uint32_t i = seg.begin; i < seg.end; ++i) f(c.pool[i]);
    if (s == last) break;
  }
}

// Replaces list l by items: in place in its first segment when they fit, else appended.
template <typename T>
void replace_list(ChainedLists<T>& c, std::uint32_t l, const std::vector<T>& items) {
  const auto n = static_cast<std::uint32_t>(items.size());
  const std::uint32_t last = c.last[l];
  if (n == 0) {
    clear_list(c, l);
    return;
  }
  const std::uint32_t first = last == kEnd<T> ? kEnd<T> : c.segments[last].next;
  if (first != kEnd<T> && c.segments[first].end - c.segments[first].begin >= n) {
    auto& seg = c.segments[first];
    std::copy(items.begin(), items.end(), c.pool.begin() + seg.begin);
    seg.end = seg.begin + n;
    seg.next = first;
    c.last[l] = first;
    if (!c.length.empty()) c.length[l] = n;
    return;
  }
  clear_list(c, l);
  const auto begin = static_cast<std::uint32_t>(c.pool.size());
  c.pool.insert(c.pool.end(), items.begin(), items.end());
  add_segment(c, l, begin, static_cast<std::uint32_t>(c.pool.size()));
}

constexpr std::uint8_t kIsolated = 1;  // no neighbour across a manifold feature edge: never merges
constexpr std::uint8_t kTarget = 2;    // absorbs a patch in the current plan
constexpr std::uint8_t kInvolved = 4;  // in a group of patches that become one this round

}  // namespace

std::uint32_t PatchMergeGraph::next_stamp() {
  if (++stamp_counter_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    stamp_counter_ = 1;
  }
  return stamp_counter_;
}

void PatchMergeGraph::reset(const PatchGraphInput& input) {
  neighbors_.pool.assign(input.neighbors.begin(), input.neighbors.end());
  reset_lists(input);
}

void PatchMergeGraph::reset_taking_neighbors(PatchGraphInput& input) {
  neighbors_.pool.swap(input.neighbors);
  reset_lists(input);
}

void PatchMergeGraph::reset_lists(const PatchGraphInput& in) {
  input_ = &in;
  const std::size_t np = in.patch_label.size();
  const std::size_t nc = in.candidate_offsets.empty() ? 0 : in.candidate_offsets.size() - 1;
  assert(in.patch_size.size() == np);
  assert(in.neighbor_offsets.size() == np + 1);
  parent_.resize(np);
  std::iota(parent_.begin(), parent_.end(), 0u);
  member_next_.assign(np, kNoPatch);
  label_.assign(in.patch_label.begin(), in.patch_label.end());
  target_.assign(np, kNoPatch);
  slot_.assign(np, kNoPatch);
  flags_.assign(np, 0);
  dead_.assign(nc, 0);
  stamp_.assign(nc, 0);
  stamp_counter_ = 0;
  merged_ = rounds_ = 0;
  // Lists grow by appended segments: reserved (address space only: pages are touched when
  // written) so that growing never copies them.
  neighbors_.segments.clear();
  neighbors_.segments.reserve(np + np / 4 + 64);
  init_chains(neighbors_, in.neighbor_offsets, false);
  // Candidate lists per patch (counted at offsets[p + 2], summed, filled at offsets[p + 1]: then
  // p's are [offsets[p], offsets[p + 1])); count_ = how many live candidates count for p.
  std::vector<std::uint32_t>& offsets = roots_;
  offsets.assign(np + 2, 0);
  for (std::uint32_t q : in.candidate_patches) ++offsets[q + 2];
  for (std::size_t k = 2; k < np + 2; ++k) offsets[k] += offsets[k - 1];
  members_.pool.clear();
  members_.pool.reserve(in.candidate_patches.size() + in.candidate_patches.size() / 4 + 64);
  members_.pool.resize(in.candidate_patches.size());
  for (std::size_t k = 0; k < nc; ++k)
    for (std::uint32_t j = in.candidate_offsets[k]; j < in.candidate_offsets[k + 1]; ++j)
      members_.pool[offsets[in.candidate_patches[j] + 1]++] = static_cast<std::uint32_t>(k);
  offsets.pop_back();
  members_.segments.clear();
  members_.segments.reserve(np + np / 4 + 64);
  init_chains(members_, offsets, true);
  count_.assign(members_.length.begin(), members_.length.end());
  small_.clear();
  for (std::size_t p = 0; p < np; ++p)
    if (count_[p] < 3) small_.push_back(static_cast<std::uint32_t>(p));
}

std::uint32_t PatchMergeGraph::compact_neighbors(std::uint32_t p) {
  scratch_.clear();
  for_each_item(neighbors_, p, [&](const Neighbor& n) {
    const std::uint32_t r = patch(n.patch);
    if (r == p) return;  // merged into p
    if (slot_[r] == kNoPatch) {
      slot_[r] = static_cast<std::uint32_t>(scratch_.size());
      scratch_.push_back({r, n.edges});
    } else {
      scratch_[slot_[r]].edges += n.edges;
    }
  });
  std::uint32_t best = kNoPatch, best_edges = 0;
  for (const Neighbor& n : scratch_) {
    slot_[n.patch] = kNoPatch;
    if (n.edges > best_edges || (n.edges == best_edges && n.patch < best)) {
      best = n.patch;
      best_edges = n.edges;
    }
  }
  replace_list(neighbors_, p, scratch_);
  return best;
}

bool PatchMergeGraph::candidate_touches(std::uint32_t candidate, std::uint32_t p) {
  const PatchGraphInput& in = *input_;
  for (std::uint32_t j = in.candidate_offsets[candidate]; j < in.candidate_offsets[candidate + 1]; ++j)
    if (patch(in.candidate_patches[j]) == p) return true;
  return false;
}

std::size_t PatchMergeGraph::round(const Reevaluate& reevaluate) {
  // The plan (plan_untriangulatable_merges' rules) over the patches with < 3 candidates, in id
  // order: only they can leave, and a patch's id order is its lowest face's.
  leaving_.clear();
  targets_.clear();
  next_small_.clear();
  for (std::uint32_t p : small_) {
    if (parent_[p] != p || count_[p] >= 3 || (flags_[p] & kIsolated)) continue;
    const std::uint32_t best = compact_neighbors(p);
    if (best == kNoPatch) {
      flags_[p] |= kIsolated;  // merges only ever join neighbours: it stays alone
      continue;
    }
    next_small_.push_back(p);
    if ((flags_[p] & kTarget) || target_[best] != kNoPatch) continue;
    target_[p] = best;
    flags_[best] |= kTarget;
    leaving_.push_back(p);
    targets_.push_back(best);
  }
  if (leaving_.empty()) {
    small_.clear();
    return 0;
  }

  // Candidates to re-evaluate: those counting for a leaving patch.
  const std::uint32_t touched_stamp = next_stamp();
  touched_.clear();
  for (std::uint32_t p : leaving_)
    for_each_item(members_, p, [&](std::uint32_t c) {
      if (dead_[c] || stamp_[c] == touched_stamp) return;
      stamp_[c] = touched_stamp;
      touched_.push_back(c);
    });
  std::sort(touched_.begin(), touched_.end());

  // Relabel, then unite adjacent patches with equal labels. Only pairs with a leaving patch can
  // become equal (adjacent patches had different labels), and leaving patches' neighbour lists
  // were just compacted. Groups are formed in a scratch union-find first, so that the merged
  // candidate lists can be computed with the patches of the round's start.
  auto new_label = [this](std::uint32_t q) { return target_[q] != kNoPatch ? label_[target_[q]] : label_[q]; };
  // The scratch union-find lives in slot_ (kNoPatch at rest: a root), with path compression.
  auto temp_find = [this](std::uint32_t x) {
    std::uint32_t r = x;
    while (slot_[r] != kNoPatch) r = slot_[r];
    while (slot_[x] != kNoPatch) x = std::exchange(slot_[x], r);
    return r;
  };
  involved_.clear();
  auto involve = [this](std::uint32_t x) {
    if (flags_[x] & kInvolved) return;
    flags_[x] |= kInvolved;
    involved_.push_back(x);
  };
  for (std::uint32_t p : leaving_) {
    const std::uint32_t lp = new_label(p);
    for_each_item(neighbors_, p, [&](const Neighbor& n) {
      if (new_label(n.patch) != lp) return;
      const std::uint32_t a = temp_find(p), b = temp_find(n.patch);
      if (a != b) slot_[std::max(a, b)] = std::min(a, b);
      involve(p);
      involve(n.patch);
    });
  }
  // Each group as a chain from its lowest id (its root in the scratch union-find).
  roots_.clear();
  for (std::uint32_t x : involved_) {
    const std::uint32_t r = temp_find(x);
    if (r == x) {
      roots_.push_back(x);
    } else {
      member_next_[x] = member_next_[r];
      member_next_[r] = x;
    }
  }
  for (std::uint32_t root : roots_) {
    // The members' candidate lists become one: the largest is kept, and the others' live
    // candidates that do not count for it already are appended (small to large, so each entry
    // moves O(log) times). "Counts for the largest" is read from a mark over the largest list
    // when that list is not much longer than the others, else from the candidate's patches.
    std::uint32_t largest = root, others = 0;
    for (std::uint32_t x = root; x != kNoPatch; x = member_next_[x])
      if (members_.length[x] > members_.length[largest]) largest = x;
    for (std::uint32_t x = root; x != kNoPatch; x = member_next_[x])
      if (x != largest) others += members_.length[x];
    const bool mark_largest = members_.length[largest] <= 4 * others;
    const std::uint32_t in_largest = next_stamp();
    if (mark_largest) for_each_item(members_, largest, [&](std::uint32_t c) { stamp_[c] = in_largest; });
    const std::uint32_t seen = next_stamp();
    extras_.clear();
    for (std::uint32_t x = root; x != kNoPatch; x = member_next_[x]) {
      if (x == largest) continue;
      for_each_item(members_, x, [&](std::uint32_t c) {
        if (dead_[c] || stamp_[c] == seen || stamp_[c] == in_largest) return;
        stamp_[c] = seen;
        if (mark_largest || !candidate_touches(c, largest)) extras_.push_back(c);
      });
    }
    const std::uint32_t merged_label = new_label(root);
    const std::uint32_t count = count_[largest] + static_cast<std::uint32_t>(extras_.size());
    if (largest != root) {
      clear_list(members_, root);
      splice(members_, root, largest);
    }
    for (std::uint32_t x = member_next_[root]; x != kNoPatch; x = member_next_[x]) {
      if (x != largest) clear_list(members_, x);
      splice(neighbors_, root, x);
      parent_[x] = root;
    }
    const auto begin = static_cast<std::uint32_t>(members_.pool.size());
    members_.pool.insert(members_.pool.end(), extras_.begin(), extras_.end());
    add_segment(members_, root, begin, static_cast<std::uint32_t>(members_.pool.size()));
    count_[root] = count;
    label_[root] = merged_label;
    next_small_.push_back(root);
  }
  for (std::uint32_t x : involved_) {
    member_next_[x] = kNoPatch;
    flags_[x] &= static_cast<std::uint8_t>(~kInvolved);
  }
  for (std::uint32_t p : leaving_) target_[p] = kNoPatch;
  for (std::uint32_t t : targets_) flags_[t] &= static_cast<std::uint8_t>(~kTarget);
  merged_ += leaving_.size();
  ++rounds_;

  // Re-evaluation: a candidate that lost its candidacy no longer counts for its patches.
  still_.assign(touched_.size(), 1);
  if (!touched_.empty()) reevaluate(*this, std::span<const std::uint32_t>(touched_), still_);
  const PatchGraphInput& in = *input_;
  for (std::size_t i = 0; i < touched_.size(); ++i) {
    if (still_[i]) continue;
    const std::uint32_t c = touched_[i];
    dead_[c] = 1;
    roots_.clear();
    for (std::uint32_t j = in.candidate_offsets[c]; j < in.candidate_offsets[c + 1]; ++j) {
      const std::uint32_t r = patch(in.candidate_patches[j]);
      if (slot_[r] != kNoPatch) continue;
      slot_[r] = 0;
      roots_.push_back(r);
    }
    for (std::uint32_t r : roots_) {
      slot_[r] = kNoPatch;
      --count_[r];
      next_small_.push_back(r);
    }
  }
  std::sort(next_small_.begin(), next_small_.end());
  next_small_.erase(std::unique(next_small_.begin(), next_small_.end()), next_small_.end());
  small_.swap(next_small_);
  return leaving_.size();
}

std::size_t PatchMergeGraph::merge(const Reevaluate& reevaluate, int max_rounds) {
  for (int r = 0; r < max_rounds; ++r)
    if (round(reevaluate) == 0) break;
  return rounds_;
}

void PatchMergeGraph::finish(PatchMergeResult& out) {
  const std::size_t np = parent_.size();
  out.patch_of.resize(np);
  out.patch_label.clear();
  out.patch_size.clear();
  for (std::size_t p = 0; p < np; ++p) {
    const std::uint32_t r = patch(static_cast<std::uint32_t>(p));
    if (r == p) {
      out.patch_of[p] = static_cast<std::uint32_t>(out.patch_label.size());
      out.patch_label.push_back(label_[p]);
    } else {
      out.patch_of[p] = out.patch_of[r];  // r < p: numbered already
    }
  }
  out.patch_size.assign(out.patch_label.size(), 0);
  for (std::size_t p = 0; p < np; ++p) out.patch_size[out.patch_of[p]] += input_->patch_size[p];
  out.adjacency.clear();
  for (std::size_t p = 0; p < np; ++p) {
    if (parent_[p] != p) continue;
    roots_.clear();
    for_each_item(neighbors_, static_cast<std::uint32_t>(p), [&](const Neighbor& n) {
      const std::uint32_t s = patch(n.patch);
      if (s <= p || slot_[s] != kNoPatch) return;
      slot_[s] = 0;
      roots_.push_back(s);
    });
    for (std::uint32_t s : roots_) slot_[s] = kNoPatch;
    std::sort(roots_.begin(), roots_.end());
    for (std::uint32_t s : roots_) out.adjacency.emplace_back(out.patch_of[p], out.patch_of[s]);
  }
  out.is_candidate.resize(dead_.size());
  for (std::size_t k = 0; k < dead_.size(); ++k) out.is_candidate[k] = !dead_[k];
  out.merged_patches = merged_;
  out.rounds = rounds_;
}

void patch_neighbors_from_pairs(std::span<const PatchPair> pairs, PatchGraphInput& input) {
  const std::size_t np = input.patch_label.size();
  std::vector<std::uint32_t>& offsets = input.neighbor_offsets;
  offsets.assign(np + 1, 0);
  for (const PatchPair& e : pairs) {
    assert(e.a != e.b && e.a < np && e.b < np);
    ++offsets[e.a + 1];
    ++offsets[e.b + 1];
  }
  for (std::size_t p = 0; p < np; ++p) offsets[p + 1] += offsets[p];
  input.neighbors.resize(offsets[np]);
  std::vector<std::uint32_t> cursor(offsets.begin(), offsets.end() - 1);
  for (const PatchPair& e : pairs) {
    input.neighbors[cursor[e.a]++] = {e.b, e.edges};
    input.neighbors[cursor[e.b]++] = {e.a, e.edges};
  }
}

void build_patch_graph(format::MeshView mesh, const MeshAdjacency& adjacency, const Patches& patches,
                       const std::vector<std::uint8_t>& feature, std::span<const std::uint32_t> candidates,
                       PatchGraphInput& out, PatchGraphBuildScratch& s) {
  const std::size_t np = patches.patch_label.size();
  const std::size_t nf = patches.face_patch.size();
  const std::uint32_t* face_patch = patches.face_patch.data();
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  const std::uint8_t* bits = feature.data();
  out.patch_label.assign(patches.patch_label.begin(), patches.patch_label.end());
  out.patch_size.assign(patches.patch_size.begin(), patches.patch_size.end());
  // Neighbours: every manifold feature edge from both of its sides (each side is an edge of a
  // face: a manifold feature edge joins faces of different labels, hence of different
  // patches), bucketed by the side's patch, then counted per neighbour.
  // Counted at bucket[p + 2]; summed, bucket[p + 1] is where p's entries start, and filling
  // moves it to where they end, so that afterwards p's are [bucket[p], bucket[p + 1]).
  s.bucket.assign(np + 2, 0);
  std::uint32_t* bucket = s.bucket.data();
  for (std::size_t f = 0; f < nf; ++f) {
    const std::uint8_t b = bits[f];
    if (!b) continue;
    for (int i = 0; i < 3; ++i) bucket[face_patch[f] + 2] += (b >> i & 1) && nb[3 * f + i] != MeshAdjacency::kNoFace;
  }
  for (std::size_t k = 2; k < np + 2; ++k) bucket[k] += bucket[k - 1];
  s.entries.resize(bucket[np + 1]);
  {
    std::uint32_t* entries = s.entries.data();
    for (std::size_t f = 0; f < nf; ++f) {
      const std::uint8_t b = bits[f];
      if (!b) continue;
      const std::uint32_t p = face_patch[f];
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t g = nb[3 * f + i];
        if ((b >> i & 1) && g != MeshAdjacency::kNoFace) entries[bucket[p + 1]++] = face_patch[g];
      }
    }
  }
  out.neighbor_offsets.resize(np + 1);
  out.neighbors.resize(s.entries.size());
  s.slot.assign(np, kNoPatch);
  std::uint32_t* slot = s.slot.data();
  PatchNeighbor* neighbors = out.neighbors.data();
  std::uint32_t n = 0;
  for (std::size_t p = 0; p < np; ++p) {
    out.neighbor_offsets[p] = n;
    const std::uint32_t first = n;
    for (std::uint32_t k = bucket[p]; k < bucket[p + 1]; ++k) {
      const std::uint32_t q = s.entries[k];
      if (slot[q] == kNoPatch) {
        slot[q] = n;
        neighbors[n++] = {q, 1};
      } else {
        ++neighbors[slot[q]].edges;
      }
    }
    for (std::uint32_t k = first; k < n; ++k) slot[neighbors[k].patch] = kNoPatch;
  }
  out.neighbor_offsets[np] = n;
  out.neighbors.resize(n);
  // Collapsed faces hold candidates but are in no star (plan_untriangulatable_merges' rule).
  s.collapsed.clear();
  if (adjacency.collapsed_faces > 0) {
    for (std::size_t f = 0; f < nf; ++f) {
      const auto& t = mesh.triangles[f];
      if (!(t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2])) continue;
      for (int i = 0; i < 3; ++i) {
        bool dup = false;
        for (int j = 0; j < i; ++j) dup = dup || t.v[j] == t.v[i];
        if (!dup) s.collapsed.emplace_back(t.v[i], face_patch[f]);
      }
    }
    std::sort(s.collapsed.begin(), s.collapsed.end());
  }
  // Distinct patches of each candidate's star (slot[q] == k marks q as listed for candidate k).
  const std::size_t nc = candidates.size();
  out.candidate_offsets.resize(nc + 1);
  out.candidate_patches.clear();
  const std::uint32_t* corners = adjacency.vertex_corners.data();
  std::size_t j = 0;
  for (std::size_t k = 0; k < nc; ++k) {
    const std::uint32_t v = candidates[k];
    const auto mark = static_cast<std::uint32_t>(k);
    assert(k == 0 || candidates[k - 1] < v);
    out.candidate_offsets[k] = static_cast<std::uint32_t>(out.candidate_patches.size());
    for (std::uint32_t c = adjacency.star_begin(v); c < adjacency.star_end(v); ++c) {
      const std::uint32_t q = face_patch[corners[c] / 3];
      if (slot[q] == mark) continue;
      slot[q] = mark;
      out.candidate_patches.push_back(q);
    }
    while (j < s.collapsed.size() && s.collapsed[j].first < v) ++j;
    for (; j < s.collapsed.size() && s.collapsed[j].first == v; ++j) out.candidate_patches.push_back(s.collapsed[j].second);
  }
  out.candidate_offsets[nc] = static_cast<std::uint32_t>(out.candidate_patches.size());
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
