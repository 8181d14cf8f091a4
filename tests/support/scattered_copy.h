// Badly ordered copies of a mesh for tests and benchmarks: vertex ids and face order shuffled
// with a fixed seed (the "scattered" inputs of docs/benchmarks.md), or the mesh as a triangle
// soup. In memory, or from one mesh file to another (holding the whole mesh).
#pragma once

#include <cstdint>
#include <string>

#include "stream/core/mesh.h"

namespace gaussmesh::testing {

// `mesh` with its vertex ids and then its face order shuffled with `seed`.
stream::Mesh scattered_mesh(stream::Mesh mesh, std::uint64_t seed);

// `mesh` as a triangle soup: each face with three vertices of its own (what STL and many
// exporters write), faces shuffled with `seed` first (0: in the input's order).
stream::Mesh soup_mesh(stream::Mesh mesh, std::uint64_t seed);

// Writes `mesh` as binary PLY to `path`; false if it cannot.
bool write_binary_ply(const std::string& path, const stream::Mesh& mesh);

// Reads `in` (any format the readers take) and writes scattered_mesh of it as binary PLY to `out`.
bool write_scattered_copy(const std::string& in, const std::string& out, std::uint64_t seed);

// Reads `in` and writes soup_mesh of it as binary PLY, or as binary STL when `stl`.
bool write_soup_copy(const std::string& in, const std::string& out, std::uint64_t seed, bool stl);

}  // namespace gaussmesh::testing
