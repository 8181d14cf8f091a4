// The whole in-core simplify of the public API on a small mesh made from fuzz bytes, run once
// without and once with a target (then with the target again, texture coordinates that make
// seams where vertices coincide, and weighed colours), its output checked for what every
// result must be: indices in range, finite positions, no face with a repeated corner, no face
// twice (as a set of vertices; unless the input has two faces over the same three positions,
// which simplify may keep, as it keeps the topology), attributes one per vertex or none, stats
// that count the output. Shared by fuzz_simplify and its regression test.
//
// Byte layout (small on purpose, so that executions stay fast):
//   byte 0: vertex count - 3, modulo kMaxFuzzVertices - 2
//   byte 1: bit 0 positions as raw float32 (else int8 lattice points, which make coincident
//           and coplanar vertices often); bit 1 indices as raw bytes, possibly out of range
//           (else modulo the vertex count); bits 2-3 the target kind (faces, ratio, max error,
//           relative max error); bit 4 the Voronoi mesher; bits 5-6 the frequency (auto, 1, 2,
//           3; auto is 4 in the run with a target); bit 7 weld on (else auto)
//   byte 2: the target's size
//   then the positions, then the triangles, three index bytes each, up to kMaxFuzzFaces.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace gaussmesh::fuzz {

inline constexpr std::size_t kMaxFuzzVertices = 64;
inline constexpr std::size_t kMaxFuzzFaces = 128;

// Both runs; the first breach, or empty. An error value from simplify is no breach.
std::string check_simplify(std::string_view bytes);

}  // namespace gaussmesh::fuzz
