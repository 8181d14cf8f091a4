// Scattered input put in spatial order (docs/partition.md, "Scattered input"). The partition
// reads vertex-indexed data (owners, chunk sets) at random through a bounded cache, once per
// face corner: on a mesh whose vertex ids or faces are shuffled, every corner misses, and the run
// slows by orders of magnitude. So `simplify` renumbers such an input first, the same way in
// core and out of core:
//   - vertices by the Morton code of their partition cell, then within the cell as VertexKey
//     says: the cell grid is the partition's (Grid::make over the bounds of the finite
//     positions), fixed by the bounds alone, so the order does not depend on --memory;
//   - with welding, vertices at exactly the same position become one (the first in that order);
//   - faces by (their lowest new corner id, their position in the input): corners keep their
//     order, so every face keeps its orientation.
// Whether an input is scattered is decided by OrderProbe on the faces in input order, with a
// fixed window, so the decision is the same for every engine and budget; a triangle soup is
// renumbered to be welded (should_weld).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "format/mesh_types.h"

namespace gaussmesh::stream {

// A face's lowest corner id (after renaming): faces are sorted by it, ties in input order.
inline std::uint32_t lowest_corner(const format::Triangle& t) { return std::min({t.v[0], t.v[1], t.v[2]}); }

// Within a cell, vertices go by the Z-order code of their sub-cell at 2^kReorderFineBits parts
// per axis, then by their coordinates' bits, then by id; a cell of more than kMaxSortedCell
// vertices (only when far outliers stretch the bounds) keeps them in id order and is not
// welded, so that one cell's sort always fits a bounded table.
inline constexpr std::uint32_t kReorderFineBits = 10;
inline constexpr std::uint32_t kMaxSortedCell = 1u << 18;

// The sort key of a vertex within its cell. Equal positions (every bit) sort next to each other.
struct VertexKey {
  std::uint32_t fine, x, y, z, id;
  static VertexKey of(std::uint32_t fine, const format::Vec3f& p, std::uint32_t id) {
    VertexKey k{fine, 0, 0, 0, id};
    std::memcpy(&k.x, &p.x, 4);
    std::memcpy(&k.y, &p.y, 4);
    std::memcpy(&k.z, &p.z, 4);
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

// Welding joins vertices whose positions are equal in every bit (so +0 and -0 stay apart) into
// the first of them in the order above. `--weld auto` welds an input with at least as many
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
