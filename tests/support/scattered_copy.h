// Badly ordered copies of a mesh file for benchmarks: vertex ids and face order shuffled with a
// fixed seed (the "scattered" inputs of docs/benchmarks.md). Holds the whole mesh.
#pragma once

#include <cstdint>
#include <string>

namespace gaussmesh::testing {

// Reads `in` (any format the readers take) and writes the shuffled copy as binary PLY to `out`.
bool write_scattered_copy(const std::string& in, const std::string& out, std::uint64_t seed);

// Writes `in` as a triangle soup: each face with three vertices of its own (what STL and many
// exporters write), faces shuffled with `seed` (0: in the input's order), as binary PLY, or as
// binary STL when `stl`.
bool write_soup_copy(const std::string& in, const std::string& out, std::uint64_t seed, bool stl);

}  // namespace gaussmesh::testing
