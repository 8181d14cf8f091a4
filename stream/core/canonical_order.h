// Orders that depend on the geometry alone, not on how the input numbers its vertices and faces,
// for the choices where the pipeline must pick one of several equal things (which patch a
// small patch joins, the order patches are triangulated in, a chain's direction): a renumbered
// copy of a mesh (shuffled, or welded from a soup, docs/partition.md) then gives the same output.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>

#include "format/mesh_types.h"
#include "stream/core/hash_mix.h"

namespace gaussmesh::stream {

// A coordinate as an unsigned key in the order of the floats: -0 as +0, and a NaN (which the
// readers refuse) after +inf or before -inf by its bits, so that keys order any value strictly.
inline std::uint32_t ordered_bits(float f) {
  const std::uint32_t u = std::bit_cast<std::uint32_t>(f == 0 ? 0.0f : f);
  return u & 0x80000000u ? ~u : u | 0x80000000u;
}

// A face's key: a hash of its three positions read from the least one (x, then y, then z), so
// the same for the face's every numbering and every rotation of its corners. Faces compare by
// (key, id): ties between distinct faces (a 64-bit collision, or two faces on the same three
// positions) fall back to the input's order.
inline std::uint64_t face_order_key(const format::Vec3f& a, const format::Vec3f& b, const format::Vec3f& c) {
  const format::Vec3f p[3] = {a, b, c};
  auto before = [](const format::Vec3f& u, const format::Vec3f& v) {
    const std::uint32_t ku[3] = {ordered_bits(u.x), ordered_bits(u.y), ordered_bits(u.z)};
    const std::uint32_t kv[3] = {ordered_bits(v.x), ordered_bits(v.y), ordered_bits(v.z)};
    return std::lexicographical_compare(ku, ku + 3, kv, kv + 3);
  };
  const int first = before(p[1], p[0]) ? (before(p[2], p[1]) ? 2 : 1) : (before(p[2], p[0]) ? 2 : 0);
  std::uint64_t h = 0x9E3779B97F4A7C15ull;
  for (int i = 0; i < 3; ++i) {
    const format::Vec3f& q = p[(first + i) % 3];
    h = mix64(h ^ (std::uint64_t{ordered_bits(q.x)} << 32 | ordered_bits(q.y)));
    h = mix64(h ^ ordered_bits(q.z));
  }
  return h;
}

}  // namespace gaussmesh::stream
