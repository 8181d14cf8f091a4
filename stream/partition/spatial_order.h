// Scattered input and soups put in spatial order, and welded (docs/partition.md, "Scattered input
// and soups"). The partition reads vertex-indexed data (owners, chunk sets) at random through a
// bounded cache, once per face corner: on a mesh whose vertex ids or faces are shuffled, every
// corner misses, and the run slows by orders of magnitude; a soup has no shared edge at all. So
// `simplify` renumbers such an input first, the same way in core and out of core:
//   - vertices by the Morton code of their partition cell, then within the cell as VertexKey
//     says: the cell grid is the partition's (Grid::make over the bounds of the finite
//     positions), fixed by the bounds alone, so the order does not depend on --memory;
//   - with welding, vertices at exactly the same position become one (the first in that order);
//   - faces by their lowest new corner id, then as order_face_group says, each turned to start
//     at that corner (lowest_first): a turn keeps the orientation, and the face spill, whose
//     columns are differences from the previous face's, compresses several times smaller.
// Whether an input is scattered is decided by OrderProbe on the faces in input order, with a
// fixed window, so the decision is the same for every engine and budget; a triangle soup is
// renumbered to be welded (should_weld).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <utility>
#include <vector>

#include "format/mesh_types.h"

namespace gaussmesh::stream {

// A face's lowest corner id (after renaming): faces are sorted by it first.
inline std::uint32_t lowest_corner(const format::Triangle& t) { return std::min({t.v[0], t.v[1], t.v[2]}); }
// The face turned to start at its (first) lowest corner, as renumbered faces are stored.
inline format::Triangle lowest_first(const format::Triangle& t) {
  const int i = t.v[0] <= t.v[1] && t.v[0] <= t.v[2] ? 0 : t.v[1] <= t.v[2] ? 1 : 2;
  return {{t.v[i], t.v[(i + 1) % 3], t.v[(i + 2) % 3]}};
}

// Faces with the same lowest corner then go by the corner after it and the one after that (in
// the face's own order, from the first lowest corner), ties in input order; a vertex that is the
// lowest corner of more than kMaxFaceGroup faces keeps them in input order, so that no group
// needs more than a bounded table. The face order then does not depend on the input's.
inline constexpr std::uint32_t kMaxFaceGroup = 1u << 16;
inline std::pair<std::uint32_t, std::uint32_t> face_tail(const format::Triangle& t) {
  const format::Triangle turned = lowest_first(t);
  return {turned.v[1], turned.v[2]};
}

// Orders the faces of one lowest corner, given in input order.
inline void order_face_group(std::span<format::Triangle> group) {
  if (group.size() < 2 || group.size() > kMaxFaceGroup) return;
  const auto before = [](const format::Triangle& a, const format::Triangle& b) { return face_tail(a) < face_tail(b); };
  if (group.size() > 32) {
    std::stable_sort(group.begin(), group.end(), before);
    return;
  }
  // A few faces (six or so around a vertex): insertion sort, stable and without the buffer
  // std::stable_sort allocates on every call.
  for (std::size_t i = 1; i < group.size(); ++i) {
    const format::Triangle t = group[i];
    std::size_t j = i;
    for (; j > 0 && before(t, group[j - 1]); --j) group[j] = group[j - 1];
    group[j] = t;
  }
}

// Within a cell, vertices go by the Z-order code of their sub-cell at 2^kReorderFineBits parts
// per axis, then by their coordinates' bits, then by id. More than kMaxWeldGroup vertices with
// one such code (a sub-cell a billionth of its cell: in practice many copies of one point) keep
// id order and are not welded, so that the out-of-core sort never needs more than a bounded
// table for one code.
inline constexpr std::uint32_t kReorderFineBits = 10;
inline constexpr std::uint32_t kMaxWeldGroup = 1u << 16;

// The sort key of a vertex within its cell. Equal positions (every bit) sort next to each other.
struct VertexKey {
  std::uint32_t fine, x, y, z, id;
  static VertexKey of(std::uint32_t fine, const format::Vec3f& p, std::uint32_t id) {
    // -0 as +0 (the same point; the STL reader's weld does the same).
    const float c[3] = {p.x == 0 ? 0.0f : p.x, p.y == 0 ? 0.0f : p.y, p.z == 0 ? 0.0f : p.z};
    VertexKey k{fine, 0, 0, 0, id};
    std::memcpy(&k.x, &c[0], 4);
    std::memcpy(&k.y, &c[1], 4);
    std::memcpy(&k.z, &c[2], 4);
    return k;
  }
  bool same_position(const VertexKey& o) const { return x == o.x && y == o.y && z == o.z; }
  bool operator<(const VertexKey& o) const {
    if (fine != o.fine) return fine < o.fine;
    if (x != o.x) return x < o.x;
    if (y != o.y) return y < o.y;
    if (z != o.z) return z < o.z;
    return id < o.id;
  }
};

// A vertex being ordered: its key (key.id: its input id) and its position.
struct OrderedVertex {
  VertexKey key;
  format::Vec3f p;
};

// Sorts keys (a fine code in the high half, an index in the low half, indices ascending) by fine
// code, keeping index order among equal codes, with `other` (as many entries) as scratch: three
// stable passes of kReorderFineBits bits, skipping a pass whose digit is the same for every key.
// The same order as sorting the keys whole, at a few passes instead of log n compares a key.
inline void radix_sort_fine(std::span<std::uint64_t> keys, std::span<std::uint64_t> other) {
  constexpr std::uint32_t kDigits = 1u << kReorderFineBits;
  std::uint64_t* from = keys.data();
  std::uint64_t* to = other.data();
  const std::size_t n = keys.size();
  for (std::uint32_t shift = 32; shift < 32 + 3 * kReorderFineBits; shift += kReorderFineBits) {
    std::uint32_t at[kDigits + 1] = {};
    for (std::size_t i = 0; i < n; ++i) ++at[((from[i] >> shift) & (kDigits - 1)) + 1];
    if (at[((from[0] >> shift) & (kDigits - 1)) + 1] == n) continue;
    for (std::uint32_t d = 0; d < kDigits; ++d) at[d + 1] += at[d];
    for (std::size_t i = 0; i < n; ++i) to[at[(from[i] >> shift) & (kDigits - 1)]++] = from[i];
    std::swap(from, to);
  }
  if (from != keys.data()) std::copy(from, from + n, keys.data());
}

// Orders `run` (vertices of one cell, whole groups of equal fine codes): by key, and a group of
// one fine code larger than kMaxWeldGroup by id. With `scratch` of at least run.size() entries,
// by fine code first on 8-byte keys (most vertices are alone in theirs), the records moved once,
// then each group of one code by its whole keys; with twice that, the 8-byte keys by radix
// (fine codes of 3 * kReorderFineBits bits).
inline void sort_run(std::span<OrderedVertex> run, std::span<std::uint64_t> scratch = {}) {
  const auto by_key = [](const OrderedVertex& a, const OrderedVertex& b) { return a.key < b.key; };
  const std::size_t n = run.size();
  if (n < 2) return;
  const bool by_fine_first = scratch.size() >= n && n <= UINT32_MAX;
  if (by_fine_first) {
    std::uint32_t all_fine = 0;
    for (std::size_t i = 0; i < n; ++i) {
      scratch[i] = std::uint64_t{run[i].key.fine} << 32 | i;
      all_fine |= run[i].key.fine;
    }
    // Small runs: a radix pass's table costs more than the compares.
    if (scratch.size() >= 2 * n && n >= 64 && all_fine >> (3 * kReorderFineBits) == 0) {
      radix_sort_fine(scratch.first(n), scratch.subspan(n, n));
    } else {
      std::sort(scratch.begin(), scratch.begin() + std::ptrdiff_t(n));
    }
    // run[i] takes the record at scratch[i]'s index, cycle by cycle; a slot done points at itself.
    const auto from = [&](std::size_t i) { return static_cast<std::uint32_t>(scratch[i]); };
    for (std::size_t i = 0; i < n; ++i) {
      if (from(i) == i) continue;
      const OrderedVertex first = run[i];
      std::size_t k = i;
      for (;;) {
        const std::size_t next = from(k);
        scratch[k] = (scratch[k] & ~std::uint64_t{UINT32_MAX}) | k;
        if (next == i) {
          run[k] = first;
          break;
        }
        run[k] = run[next];
        k = next;
      }
    }
  } else {
    std::sort(run.begin(), run.end(), by_key);
  }
  // Each group of one fine code: by its whole keys (if not sorted so already), past
  // kMaxWeldGroup by id.
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i + 1;
    while (j < n && run[j].key.fine == run[i].key.fine) ++j;
    const auto group = run.subspan(i, j - i);
    if (group.size() > kMaxWeldGroup) {
      std::sort(group.begin(), group.end(), [](const OrderedVertex& a, const OrderedVertex& b) { return a.key.id < b.key.id; });
    } else if (by_fine_first && group.size() > 1) {
      std::sort(group.begin(), group.end(), by_key);
    }
    i = j;
  }
}

// Calls emit(vertex, joined) for each vertex of a run sorted by sort_run, in order; joined:
// welded into the last vertex emitted unjoined (never within a group past kMaxWeldGroup).
template <class Emit>
void emit_run(std::span<const OrderedVertex> run, bool weld, Emit&& emit) {
  for (std::size_t i = 0; i < run.size();) {
    std::size_t j = i + 1;
    while (j < run.size() && run[j].key.fine == run[i].key.fine) ++j;
    const bool large = j - i > kMaxWeldGroup;
    for (std::size_t k = i; k < j; ++k) emit(run[k], weld && !large && k > i && run[k].key.same_position(run[k - 1].key));
    i = j;
  }
}

template <class Emit>
void order_run(std::span<OrderedVertex> run, bool weld, Emit&& emit) {
  sort_run(run);
  emit_run(run, weld, emit);
}

// Welding joins vertices whose coordinates are equal in every bit (-0 taken as +0; NaNs only
// with the same bits) into the first of them in the order above. `--weld auto` welds an input with at least as many
// vertices as faces: a triangle soup has three a face, a mesh that shares its vertices about one
// for two faces.
enum class Weld { kAuto, kOn, kOff };
inline bool looks_like_soup(std::uint64_t vertices, std::uint64_t faces) { return faces > 0 && vertices >= faces; }
inline bool should_weld(Weld weld, std::uint64_t vertices, std::uint64_t faces) {
  return weld == Weld::kOn || (weld == Weld::kAuto && looks_like_soup(vertices, faces));
}

// Counts the corners that fall outside a small window of recently used vertex ids: a
// direct-mapped table of kSlots blocks of 2^kBlockBits ids (256 Ki ids in all). On spatially
// ordered meshes (scans, subdivided meshes, CAD exports) under 0.1 % of corners miss; with
// shuffled ids nearly half do. An input is scattered when it has more vertices than the window
// and more than one corner in kScatteredShare misses.
class OrderProbe {
 public:
  static constexpr std::uint32_t kBlockBits = 8;
  static constexpr std::uint32_t kSlots = 1024;
  static constexpr std::uint64_t kScatteredShare = 16;

  OrderProbe() : tags_(kSlots, UINT32_MAX) {}
  void add(std::span<const format::Triangle> faces) {
    for (const format::Triangle& t : faces) {
      for (const std::uint32_t v : t.v) {
        const std::uint32_t block = v >> kBlockBits;
        std::uint32_t& tag = tags_[block & (kSlots - 1)];
        misses_ += tag != block;
        tag = block;
      }
    }
    corners_ += 3 * faces.size();
  }
  bool scattered(std::uint64_t vertices) const {
    return vertices > (std::uint64_t{kSlots} << kBlockBits) && misses_ * kScatteredShare > corners_;
  }
  std::uint64_t misses() const { return misses_; }
  std::uint64_t corners() const { return corners_; }

 private:
  std::vector<std::uint32_t> tags_;
  std::uint64_t misses_ = 0, corners_ = 0;
};

// Renumbers a mesh in memory by the rules above (whatever the probe says), welding equal
// positions when `weld`: positions and faces are rewritten in place. Returns the number of
// vertices welded away. Corners out of range are left as they are (the readers refuse them).
std::uint64_t reorder_spatially(std::vector<format::Vec3f>& positions, std::vector<format::Triangle>& faces, bool weld);

}  // namespace gaussmesh::stream
