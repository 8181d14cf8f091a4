// Morton (Z-order) codes: the bits of three cell coordinates interleaved, so that sorting by the
// code keeps cells that are near in space near in the order.
#pragma once

#include <cstdint>

namespace gaussmesh::stream {

// Spreads the low 21 bits of x to every third bit (bit i to bit 3i); a code is
// spread21(x) | spread21(y) << 1 | spread21(z) << 2.
inline std::uint64_t spread21(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

}  // namespace gaussmesh::stream
