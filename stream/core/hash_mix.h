// splitmix64's finalizer: the 64-bit mix behind the stitch's bucket hashes (stream/stitch/piece_joins)
// and the mesher's chain-path hashes (stream/meshing/polygon_mesher).
#pragma once

#include <cstdint>

namespace gaussmesh::stream {

inline std::uint64_t mix64(std::uint64_t x) {
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace gaussmesh::stream
