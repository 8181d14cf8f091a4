// Scattered input put in spatial order (docs/partition.md, "Scattered input"). The partition
// reads vertex-indexed data (owners, chunk sets) at random through a bounded cache, once per
// face corner: on a mesh whose vertex ids or faces are shuffled, every corner misses, and the run
// slows by orders of magnitude. So `simplify` renumbers such an input first, the same way in
// core and out of core:
//   - vertices by (the Morton code of their partition cell, their id): the cell grid is the
//     partition's (Grid::make over the bounds of the finite positions), fixed by the bounds
//     alone, so the order does not depend on --memory;
//   - faces by (their lowest new corner id, their position in the input): corners keep their
//     order, so every face keeps its orientation.
// Whether an input is scattered is decided by OrderProbe on the faces in input order, with a
// fixed window, so the decision is the same for every engine and budget.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "format/mesh_types.h"

namespace gaussmesh::stream {

// A face's lowest corner id (after renaming): faces are sorted by it, ties in input order.
inline std::uint32_t lowest_corner(const format::Triangle& t) { return std::min({t.v[0], t.v[1], t.v[2]}); }

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

// Renumbers a mesh in memory by the rules above (whatever the probe says): positions and faces
// are rewritten in place. Corners out of range are left as they are (the readers refuse them).
void reorder_spatially(std::vector<format::Vec3f>& positions, std::vector<format::Triangle>& faces);

}  // namespace gaussmesh::stream
