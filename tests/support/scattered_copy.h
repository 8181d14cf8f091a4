// A badly ordered copy of a mesh file for benchmarks: vertex ids and face order shuffled with a
// fixed seed (the "scattered" inputs of docs/benchmarks.md). Holds the whole mesh.
#pragma once

#include <cstdint>
#include <string>

namespace gaussmesh::testing {

// Reads `in` (any format the readers take) and writes the shuffled copy as binary PLY to `out`.
bool write_scattered_copy(const std::string& in, const std::string& out, std::uint64_t seed);

}  // namespace gaussmesh::testing
