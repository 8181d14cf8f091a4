// Orders that depend on the geometry alone, not on how the input numbers its vertices and faces,
// for the choices where the pipeline must pick one of several equal things (which patch a
// small patch joins, the order patches are triangulated in, a chain's direction): a renumbered
// copy of a mesh (shuffled, or welded from a soup, docs/partition.md) then gives the same output.
#pragma once

#include <bit>
#include <cstdint>
#include <tuple>

#include "format/mesh_types.h"
#include "stream/core/hash_mix.h"

namespace gaussmesh::stream {

// A coordinate as an unsigned key in the order of the floats: -0 as +0, and a NaN (which the
// readers refuse) after +inf or before -inf by its bits, so that keys order any value strictly.
inline std::uint32_t ordered_bits(float f) {
  const std::uint32_t u = std::bit_cast<std::uint32_t>(f == 0 ? 0.0f : f);
  return u & 0x80000000u ? ~u : u | 0x80000000u;
}

// A vertex's place in the position order: x, then y, then z, then its id (between vertices at
// the same position only).
using PositionKey = std::tuple<std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t>;
inline PositionKey position_key(const format::Vec3f& p, std::uint32_t id) {
  return {ordered_bits(p.x), ordered_bits(p.y), ordered_bits(p.z), id};
}

// A vertex's hash: of its position's ordered bits, the same for each of its numberings.
inline std::uint64_t position_hash(const format::Vec3f& p) {
  return mix64(mix64(std::uint64_t{ordered_bits(p.x)} << 32 | ordered_bits(p.y)) ^ ordered_bits(p.z));
}

// A face's key from its corners' position hashes, in the face's order: a sum over its three
// directed edges, so the same from every corner but not for the other orientation (another
// face). Faces compare by (key, id): ties between distinct faces (a 64-bit collision, or two
// faces on the same three positions) fall back to the input's order.
inline std::uint64_t face_order_key(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  return mix64((a ^ std::rotl(b, 17)) + (b ^ std::rotl(c, 17)) + (c ^ std::rotl(a, 17)));
}
inline std::uint64_t face_order_key(const format::Vec3f& a, const format::Vec3f& b, const format::Vec3f& c) {
  return face_order_key(position_hash(a), position_hash(b), position_hash(c));
}

}  // namespace gaussmesh::stream
