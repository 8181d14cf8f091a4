// The cell grid of the partition: the input's bounds cut into at most 2^18 cells in Morton
// order, split cells' sub-cells, and the chunk owning a position.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "format/mesh_types.h"
#include "stream/partition/chunk_partition.h"

namespace gaussmesh::stream::detail {

using format::Vec3f;

constexpr std::uint32_t kCellBits = 18;  // at most 2^18 cells: histogram and table 1 MiB each
constexpr std::uint32_t kMaxSplitBits = 5;  // a split cell has at most 8^5 sub-cells (128 KiB of counts)

// The bounds of the finite coordinates, axis by axis (an axis with none gets 0..0): what the
// grid is cut from. The ingest and the in-core renumbering both take them so, to the same bits.
class FiniteBounds {
 public:
  void add(const Vec3f& p) {
    const float c[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(c[a])) continue;
      lo_[a] = std::min(lo_[a], c[a]);
      hi_[a] = std::max(hi_[a], c[a]);
    }
  }
  void get(Vec3f& lo, Vec3f& hi) const {
    float l[3], h[3];
    for (int a = 0; a < 3; ++a) {
      const bool any = lo_[a] <= hi_[a];
      l[a] = any ? lo_[a] : 0;
      h[a] = any ? hi_[a] : 0;
    }
    lo = {l[0], l[1], l[2]};
    hi = {h[0], h[1], h[2]};
  }

 private:
  float lo_[3] = {INFINITY, INFINITY, INFINITY}, hi_[3] = {-INFINITY, -INFINITY, -INFINITY};
};

struct Grid {
  double lo[3] = {0, 0, 0}, scale[3] = {0, 0, 0};
  std::uint32_t bits[3] = {0, 0, 0};
  std::uint32_t n[3] = {1, 1, 1};

  // Per-axis bits so that cells are as close to cubes as 2^kCellBits cells allow.
  static Grid make(const Vec3f& lo, const Vec3f& hi) {
    Grid g;
    const double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    double extent[3];
    for (int a = 0; a < 3; ++a) {
      g.lo[a] = l[a];
      extent[a] = h[a] - l[a];
      if (!(extent[a] > 0) || !std::isfinite(extent[a])) extent[a] = 0;
    }
    for (std::uint32_t b = 0; b < kCellBits; ++b) {
      int best = -1;
      double best_size = 0;
      for (int a = 0; a < 3; ++a) {
        const double size = std::ldexp(extent[a], -static_cast<int>(g.bits[a]));
        if (extent[a] > 0 && size > best_size) {
          best = a;
          best_size = size;
        }
      }
      if (best < 0) break;
      ++g.bits[best];
    }
    for (int a = 0; a < 3; ++a) {
      g.n[a] = 1u << g.bits[a];
      g.scale[a] = extent[a] > 0 ? g.n[a] / extent[a] : 0;
    }
    return g;
  }
  std::size_t cells() const { return std::size_t{n[0]} * n[1] * n[2]; }
  std::uint32_t axis(int a, float value) const {
    const double t = (static_cast<double>(value) - lo[a]) * scale[a];
    if (!(t >= 0)) return 0;  // below, or NaN
    if (t >= n[a]) return n[a] - 1;
    return static_cast<std::uint32_t>(t);
  }
  std::uint32_t cell(const Vec3f& p) const {
    return axis(0, p.x) + n[0] * (axis(1, p.y) + n[1] * axis(2, p.z));
  }
  // Z-order code of p's sub-cell when its cell is split into 2^k parts per axis (axes of zero
  // extent stay whole). The fine coordinate is floor(t * 2^k) on the cell's own t: scaling by a
  // power of two is exact (a multiplication, not std::ldexp, which is a libm call per vertex),
  // so it always lies inside the cell that cell(p) names.
  std::uint32_t sub_code(const Vec3f& p, std::uint32_t k) const {
    const float c[3] = {p.x, p.y, p.z};
    std::uint32_t local[3] = {0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      if (scale[a] == 0) continue;
      const double t = (static_cast<double>(c[a]) - lo[a]) * scale[a];
      const std::uint64_t parts = std::uint64_t{1} << k;
      std::uint64_t fine = 0;
      if (t >= n[a]) {
        fine = std::uint64_t{n[a]} * parts - 1;
      } else if (t >= 0) {
        fine = std::min<std::uint64_t>(static_cast<std::uint64_t>(t * static_cast<double>(parts)), std::uint64_t{n[a]} * parts - 1);
      }
      local[a] = static_cast<std::uint32_t>(fine - (std::uint64_t{axis(a, c[a])} << k));
    }
    if (k <= 10) return spread_bits(local[0]) << 2 | spread_bits(local[1]) << 1 | spread_bits(local[2]);
    std::uint32_t code = 0;
    for (std::uint32_t level = k; level-- > 0;)
      for (int a = 0; a < 3; ++a) code = code << 1 | ((local[a] >> level) & 1u);
    return code;
  }
  // The low 10 bits of x moved to every third bit (bit i to bit 3i): one axis of a Z-order code.
  static std::uint32_t spread_bits(std::uint32_t x) {
    x &= 0x3FFu;
    x = (x | x << 16) & 0x030000FFu;
    x = (x | x << 8) & 0x0300F00Fu;
    x = (x | x << 4) & 0x030C30C3u;
    x = (x | x << 2) & 0x09249249u;
    return x;
  }
  // Z-order code of a cell: bits interleaved from the top level down; an axis with fewer bits
  // joins the interleave at its own top level.
  std::uint32_t morton(std::uint32_t linear) const {
    const std::uint32_t i[3] = {linear % n[0], (linear / n[0]) % n[1], linear / (n[0] * n[1])};
    std::uint32_t code = 0;
    const std::uint32_t top = std::max({bits[0], bits[1], bits[2]});
    for (std::uint32_t level = top; level-- > 0;)
      for (int a = 0; a < 3; ++a)
        if (level < bits[a]) code = code << 1 | ((i[a] >> level) & 1u);
    return code;
  }
};

// The chunk of p: its cell's, or for a split cell its sub-cell's (Partition::OwnerMap).
inline std::uint32_t owner_in(const Grid& grid, const std::vector<std::uint32_t>& cell_chunk,
                       const std::vector<Partition::SplitCell>& splits, const Vec3f& p) {
  const std::uint32_t cell = grid.cell(p);
  if (cell >= cell_chunk.size()) return 0;
  const std::uint32_t entry = cell_chunk[cell];
  if (!(entry & Partition::kSplitCell)) return entry;
  const std::uint32_t index = entry & ~Partition::kSplitCell;
  if (index >= splits.size()) return 0;
  const Partition::SplitCell& split = splits[index];
  const std::uint32_t code = grid.sub_code(p, split.k);
  return split.first + static_cast<std::uint32_t>(std::upper_bound(split.starts.begin(), split.starts.end(), code) -
                                                  split.starts.begin());
}

}  // namespace gaussmesh::stream::detail
